"""The optimum of a laser log: its pose graph (``mazeslam.posegraph``: the laser odometry and loop
closures, solved robustly) carried to every record, and the map its poses draw; what ``mazeslam
smooth`` writes for a grid config and what the grid filter's report is measured against
(``mazeslam.smoothing.optimum.optimum_columns``).

Settings: the config's ``[scan_matching]`` (the laser odometry and the matches' points),
``[posegraph]`` (edges, closures, the robust solve) and ``[grid.grid]`` (the map's cells). Odometry
records the filters leave out as glitches (``[odometry] jump_tolerance``) move nothing here either.
"""

from __future__ import annotations

import dataclasses
import time
from functools import cached_property

import numpy as np

from mazeslam.core.motion import carried_to_records
from mazeslam.data.loaded_run import LoadedRun
from mazeslam.gridslam.filter import odometry_at_record_times
from mazeslam.gridslam.known_poses import map_at_poses
from mazeslam.gridslam.occupancy import TiledGrid, grid_states
from mazeslam.pipeline.config import SlamConfig
from mazeslam.posegraph.laser_graph import PoseGraphResult, laser_pose_graph


@dataclasses.dataclass(kw_only=True)
class LaserSmoothed:
    """The pose graph of a laser log, at every record.

    Attributes:
        graph: the solved graph at the scans (``PoseGraphResult``: poses, covariances, edges, closures).
        poses: (R, 3) pose at every record: a scan's from the graph, a record between scans the last
            scan's moved on by the odometry since (``carried_to_records``); world frame, m and rad.
        covariances: (R, 3, 3) the last scan's covariance (relative to the first scan).
        grid: the log's scans integrated at the graph's poses (``map_at_poses``).
        seconds: wall-clock seconds of the graph and the map.
    """

    graph: PoseGraphResult
    poses: np.ndarray
    covariances: np.ndarray
    grid: TiledGrid
    seconds: float

    @cached_property
    def occupancy(self):
        """The map's cell states (``grid_states``), worked out once for its files and figure."""
        return grid_states(self.grid)


def has_laser_optimum(run: LoadedRun) -> bool:
    """The run's pose graph can be built and scored: truth beside a log of scans, no landmark records."""
    return run.truth is not None and run.log.scans_only


def smooth_laser_run(run: LoadedRun, config: SlamConfig) -> LaserSmoothed:
    """The pose graph of ``run``'s scans with ``config``'s settings (see the module docstring)."""
    if not run.log.scans_only:
        raise ValueError(f"{run.path}: the pose graph needs a log of scans (and no landmark records)")
    began = time.perf_counter()
    course_log = run.log_with_glitch_pairs_summed(config.odometry.jump_tolerance)
    cleaned = dataclasses.replace(run, log=course_log)
    graph = laser_pose_graph(cleaned, config, config.posegraph)
    reckoned = odometry_at_record_times(course_log, run.start_pose)
    start = np.asarray(run.start_pose, dtype=float)
    poses, covariances = carried_to_records(graph.scan_records, graph.poses, graph.covariances, reckoned, start)
    grid = map_at_poses(course_log, run.geometry, graph.poses, config.grid.grid, run.sensor_max_range)
    return LaserSmoothed(
        graph=graph, poses=poses, covariances=covariances, grid=grid, seconds=time.perf_counter() - began
    )
