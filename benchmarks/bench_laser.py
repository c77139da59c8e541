"""Benchmark: one 180-beam scan in a 16 x 16 maze, vectorised ray casting vs pymunk per-ray queries.

The baseline casts the same beams from the same poses with pymunk's ``segment_query_first`` (one
query per beam against the same wall boxes), measured in the same run. Target: at least 5x faster.
Run: ``python benchmarks/bench_laser.py``.
"""

from __future__ import annotations

import time

import numpy as np
import pymunk

from mazeslam.sim.laser import LaserParams, VirtualLaser
from mazeslam.sim.maze import generate_maze
from mazeslam.sim.walls import wall_geometry

TARGET_SPEEDUP = 5.0


def sample_poses(maze, count, rng):
    cells = rng.integers([0, 0], [maze.rows, maze.cols], size=(count, 2))
    centres = np.array([maze.cell_center(*cell) for cell in cells])
    return np.column_stack([centres + rng.uniform(-0.02, 0.02, (count, 2)), rng.uniform(-np.pi, np.pi, count)])


def best_time_per_call(function, poses, repeats=5):
    """Smallest mean seconds per call over ``repeats`` passes through ``poses``."""
    best = np.inf
    for _ in range(repeats):
        start = time.perf_counter()
        for pose in poses:
            function(pose)
        best = min(best, (time.perf_counter() - start) / len(poses))
    return best


def run() -> dict:
    maze = generate_maze(16, 16, 0, loop_fraction=0.1)
    walls = wall_geometry(maze)
    params = LaserParams(beams=180, range_noise_std=0.0)
    laser = VirtualLaser(params, walls.surfaces)
    space = pymunk.Space()
    for xmin, ymin, xmax, ymax in walls.boxes:
        space.add(pymunk.Poly(space.static_body, [(xmin, ymin), (xmax, ymin), (xmax, ymax), (xmin, ymax)]))
    query_filter = pymunk.ShapeFilter()

    def pymunk_scan(pose):
        angles = pose[2] + laser.bearings
        ends = pose[:2] + params.max_range * np.column_stack([np.cos(angles), np.sin(angles)])
        start = (pose[0], pose[1])
        return [space.segment_query_first(start, (x, y), 0, query_filter) for x, y in ends]

    poses = sample_poses(maze, 200, np.random.default_rng(1))
    ours = best_time_per_call(laser.true_ranges, poses)
    baseline = best_time_per_call(pymunk_scan, poses)
    return {
        "benchmark": "180-beam scan, 16x16 maze",
        "mazeslam_ms_per_scan": 1e3 * ours,
        "pymunk_ms_per_scan": 1e3 * baseline,
        "speedup": baseline / ours,
        "target": TARGET_SPEEDUP,
        "met": baseline / ours >= TARGET_SPEEDUP,
    }


if __name__ == "__main__":
    print(run())
