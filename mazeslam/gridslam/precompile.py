"""Compile the grid filter's and the laser odometry's kernels into numba's cache before a first run
needs them.

``python -m mazeslam.gridslam.precompile`` (``make install`` runs it) runs the filter, in both
search modes and moved by laser odometry, over a few noise-free scans of a rectangular room, and
one match as a failed match's rescue runs it: that calls every kernel with the argument types a
real run passes, so numba compiles each once (about 15 s) and later runs load them from the cache
(``mazeslam.gridslam.kernels``, ``mazeslam.registration.kernels``). Without it the first run on a
machine compiles them itself.
"""

from __future__ import annotations

import time

import numpy as np

from mazeslam.core.beams import BeamGeometry
from mazeslam.data.log import ODOMETRY, SCAN, CourseLog
from mazeslam.gridslam.filter import GridSlamParams, MotionSource, SearchMode, run_grid_slam
from mazeslam.gridslam.matching import LikelihoodField, MatchParams, match_pose
from mazeslam.gridslam.occupancy import GridParams, Window

#: The room: lower and upper corner of its walls, m.
ROOM = np.array([[-1.0, -1.5], [4.0, 1.5]])
BEAMS = 90
STEP = 0.6  # m between scans: more than the default linear_update, so that every scan is processed


def room_ranges(pose: np.ndarray, bearings: np.ndarray) -> np.ndarray:
    """Ranges (N,) m from ``pose`` (3,) along ``bearings`` (N,) rad to the walls of ``ROOM``."""
    direction = np.column_stack([np.cos(pose[2] + bearings), np.sin(pose[2] + bearings)])  # (N, 2)
    with np.errstate(divide="ignore"):
        to_walls = (np.where(direction > 0, ROOM[1], ROOM[0]) - pose[:2]) / direction  # (N, 2) along each axis
    return np.min(np.where(to_walls > 0, to_walls, np.inf), axis=1)


def room_log(scans: int = 6) -> tuple[CourseLog, BeamGeometry]:
    """A log driving straight along x through ``ROOM``: an odometry record of ``STEP`` m, then a scan."""
    geometry = BeamGeometry()
    bearings = geometry.bearings(BEAMS)
    times: list[float] = []
    flags: list[int] = []
    rows: list[np.ndarray] = []
    for index in range(scans):
        odometry = np.full(BEAMS, -1.0)
        odometry[:2] = (STEP if index else 0.0, 0.0)
        pose = np.array([index * STEP, 0.0, 0.0])
        for flag, row in ((ODOMETRY, odometry), (SCAN, room_ranges(pose, bearings))):
            times.append(0.5 * len(times))
            flags.append(flag)
            rows.append(row)
    return CourseLog(np.array(times), np.array(flags), np.array(rows)), geometry


def rescue_match() -> None:
    """One match as a particle's rescue runs it, particle by particle (``match_pose`` on a window's
    cells, outside ``match_all``): the room's scans never make a match fail."""
    params = GridParams()
    values = np.zeros((2 * params.tile_size, 2 * params.tile_size), dtype=np.float32)
    values[10:100, 40] = 1.0  # a wall
    field = LikelihoodField(Window(values, np.zeros(2), 0.05, np.zeros(2, dtype=int)), MatchParams())
    points = np.column_stack([np.full(20, 0.5), np.linspace(-1.0, 1.0, 20)])
    match_pose(field, points, np.array([1.5, 2.5, 0.0]), np.eye(3), MatchParams())


def main() -> None:
    began = time.perf_counter()
    course_log, geometry = room_log()
    for search in SearchMode:
        params = GridSlamParams(particles=3, motion=MotionSource.LASER, search=search)
        run_grid_slam(course_log, geometry, np.zeros(3), params)
    rescue_match()
    seconds = time.perf_counter() - began
    print(f"the grid filter's and the laser odometry's kernels are compiled and cached ({seconds:.1f} s)")


if __name__ == "__main__":
    main()
