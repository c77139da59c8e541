"""The grid filter over a loaded log (``mazeslam.gridslam``), its result as a ``SlamResult``."""

from __future__ import annotations

import dataclasses

import numpy as np

from mazeslam.core.motion import dead_reckoning
from mazeslam.data.loaded_run import LoadedRun
from mazeslam.gridslam.filter import GridSlamParams, run_grid_slam
from mazeslam.pipeline.config import MapKind, SlamConfig
from mazeslam.pipeline.result import SlamResult


def grid_params(config: SlamConfig) -> GridSlamParams:
    """``[grid]``, moving by ``[scan_matching]``'s laser odometry when that is enabled."""
    if config.scan_matching.enabled:
        return dataclasses.replace(config.grid, laser_odometry=config.scan_matching)
    return config.grid


def grid_on_run(
    run: LoadedRun, config: SlamConfig, progress: bool = False, snapshot_every: int = 0, on_update=None
) -> SlamResult:
    """The grid filter over ``run``, moving by its odometry with the glitch pairs summed and lone
    glitches left out (``[odometry] jump_tolerance``), the sensor's maximum range from the map
    sidecar (``[grid.grid] clear_no_return``); ``snapshot_every``: keep the best particle's map and
    the particles every that many scans, for an animation (``GridSnapshot``s in ``snapshots``);
    ``on_update(record_index, filter)`` after every scan, for a live view.

    Poses at the records between two scans are the last scan's moved on by the odometry since
    (``GridSlamResult.record_trajectory``); the scans are the ``estimated_records``."""
    tolerance = config.odometry.jump_tolerance
    moved_by = run.log_with_glitch_pairs_summed(tolerance)
    params = grid_params(config)
    grid_run = run_grid_slam(
        moved_by, run.geometry, run.start_pose, params, progress, snapshot_every, run.sensor_max_range, on_update
    )
    mean, covariances = grid_run.record_trajectory(which="mean")
    seconds = np.zeros(len(run.log))
    seconds[grid_run.scan_records] = grid_run.seconds
    return SlamResult(
        kind=MapKind.GRID,
        times=run.log.times,
        mean_poses=mean,
        best_poses=grid_run.record_trajectory(which="best")[0],
        pose_covariances=covariances,
        estimated_records=grid_run.scan_records,
        dead_reckoning=dead_reckoning(run.log, run.start_pose, run.glitches(tolerance)),
        step_seconds=seconds,
        grid=grid_run.grid,
        nis=grid_run.nis[np.isfinite(grid_run.nis)],
        nis_dof=3,
        updates=int(grid_run.processed.sum()),
        resamplings=grid_run.resamplings,
        snapshots=grid_run.snapshots,
        filter=grid_run.particles,
        grid_run=grid_run,
    )
