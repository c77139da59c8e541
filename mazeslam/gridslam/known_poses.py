"""Mapping with known poses: every scan of a log integrated into one occupancy grid at a pose given
for it (a smoother's, or a log's reference poses), as the grid filter integrates a scan into a
particle's map (``scan_rays``, ``integrate_scan``)."""

from __future__ import annotations

import numpy as np

from mazeslam.core.beams import BeamGeometry
from mazeslam.core.geometry import transform_points
from mazeslam.data.log import CourseLog
from mazeslam.gridslam.filter import ScanSensor
from mazeslam.gridslam.occupancy import GridParams, TiledGrid, integrate_scan, scan_rays


def map_at_poses(
    course_log: CourseLog, geometry: BeamGeometry, poses: np.ndarray, params: GridParams, sensor_max_range: float = 0.0
) -> TiledGrid:
    """The grid of every scan of ``course_log`` taken at ``poses`` (S, 3), one robot pose (world
    frame, m and rad) per scan record in log order. ``sensor_max_range`` (m, 0 unknown): how far a
    beam with no return clears the map with ``params.clear_no_return``, as in the grid filter."""
    scans = course_log.values[course_log.is_scan]
    if len(poses) != len(scans):
        raise ValueError(f"{len(poses)} poses for {len(scans)} scans: one pose per scan")
    sensor = ScanSensor.of(geometry, course_log.width, sensor_max_range)
    clears_to = sensor.max_range if params.clear_no_return else 0.0
    grid = TiledGrid(params)
    for ranges, pose in zip(scans, np.asarray(poses, dtype=float)):
        rays = scan_rays(ranges, sensor.bearings, sensor.mount, params, clears_to)
        reach = np.vstack([transform_points(pose, rays.reach), pose[None, :2]])
        window = grid.window(*grid.tile_range(reach, 0.0))
        grid.store(window, integrate_scan(window, rays, pose, params))
    return grid
