"""The grid filter over a loaded log (``mazeslam.gridslam``), its result as a ``SlamResult``."""

from __future__ import annotations

import numpy as np

from mazeslam.core.limits import grid_map_problem
from mazeslam.core.motion import dead_reckoning
from mazeslam.data.loaded_run import LoadedRun
from mazeslam.gridslam.filter import GridDivergence, GridSlamParams, run_grid_slam
from mazeslam.pipeline.config import MapKind, SlamConfig
from mazeslam.pipeline.result import SlamResult


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
    params = config.grid_filter
    glitches = run.glitches(tolerance)
    reckoned = dead_reckoning(run.log, run.start_pose, glitches)
    _check_mappable(run, reckoned, glitches, params)
    try:
        grid_run = run_grid_slam(
            moved_by, run.geometry, run.start_pose, params, progress, snapshot_every, run.sensor_max_range, on_update
        )
    except GridDivergence as error:  # it names the log's line, not the file
        raise GridDivergence(f"{run.path}: {error}") from None
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
        dead_reckoning=reckoned,
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


def _check_mappable(run: LoadedRun, reckoned: np.ndarray, glitches: np.ndarray, params: GridSlamParams) -> None:
    """Refuse, in words, a log the grid filter cannot map: one without scans, one whose scans have no
    return the grid uses (``[grid.grid] min_range``, ``max_range``), or one whose odometry
    (``reckoned`` (R, 3), the ``glitches`` (indices) left out) spans a map too big to hold
    (``limits.grid_map_problem``)."""
    grid, course_log = params.grid, run.log
    scans = course_log.values[course_log.is_scan] if course_log.n_beams else np.empty((0, 0))
    if not len(scans):
        raise ValueError(
            f'{run.path}: no scan records: the grid filter ([map] kind = "grid") maps laser scans; '
            'a log of landmark observations or odometry alone needs [map] kind = "landmarks"'
        )
    if not np.any((scans > 0) & (scans >= grid.min_range) & (scans <= grid.max_range)):
        raise ValueError(
            f"{run.path}: no scan has a return between [grid.grid] min_range = {grid.min_range:g} m and "
            f"max_range = {grid.max_range:g} m: there is nothing to map"
        )
    width, height = reckoned[:, :2].max(axis=0) - reckoned[:, :2].min(axis=0) + 2 * grid.max_range
    problem = grid_map_problem(width, height, grid.resolution)
    if problem:
        step, metres = course_log.longest_step(left_out=glitches)
        raise ValueError(
            f"{run.path}: the odometry spans {width:.0f} m x {height:.0f} m (its longest step, "
            f"{course_log.line_of(step)}, {metres:.3g} m): {problem}. A glitch? [odometry] jump_tolerance "
            "leaves out steps longer than it"
        )
