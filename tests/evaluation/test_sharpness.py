"""Map sharpness: occupied 1 cm cells of the scans placed along a path, against hand-built scans."""

import math
from pathlib import Path

import numpy as np
import pytest

from mazeslam.core.beams import BeamGeometry
from mazeslam.data import log
from mazeslam.data.loaded_run import LoadedRun
from mazeslam.evaluation.sharpness import Sharpness, map_sharpness, occupied_cells, path_extent

BEAMS = 360
FORWARD = BeamGeometry(first_beam_angle=0.0, direction=1)
WALL_X = 0.305  # a wall along y at x = 0.305 m (mid-cell), seen from robots on the x axis


def wall_ranges(robot_x: float) -> np.ndarray:
    """360 ranges (beam k at +k deg) from (robot_x, 0) heading +x to the wall x = WALL_X; 0 where a
    beam does not hit it within 0.4 m."""
    bearings = np.radians(np.arange(BEAMS))
    with np.errstate(divide="ignore"):
        ranges = (WALL_X - robot_x) / np.cos(bearings)
    return np.where((ranges > 0) & (ranges <= 0.4), ranges, 0.0)


def course_log(lines: list[str]) -> log.CourseLog:
    return log.parse("\n".join(lines) + "\n", source="hand-built.log")


def scan_line(t: float, ranges: np.ndarray) -> str:
    return f"{t:.1f} 1 " + " ".join(f"{r:.6f}" for r in ranges)


def odometry_line(t: float, distance: float) -> str:
    return f"{t:.1f} 0 {distance:.6f} 0 " + " ".join(["-1"] * (BEAMS - 2))


def test_scans_at_their_true_poses_occupy_the_walls_cells_and_a_wrong_pose_smears_them():
    records = course_log([scan_line(0.0, wall_ranges(0.0)), scan_line(0.1, wall_ranges(0.05))])
    true_poses = np.array([[0.0, 0.0, 0.0], [0.05, 0.0, 0.0]])
    # Independent count: the wall's hits all lie in cell column 30 (x = 0.305 m), so the cells are
    # the distinct y cells of both scans' returns of 0.05-0.4 m, by hand.
    points = []
    for robot_x, ranges in zip((0.0, 0.05), records.values):
        bearings = np.radians(np.arange(BEAMS))[ranges >= 0.05]
        kept = ranges[ranges >= 0.05]
        points.append(np.column_stack([robot_x + kept * np.cos(bearings), kept * np.sin(bearings)]))
    expected = len({(math.floor(x / 0.01), math.floor(y / 0.01)) for x, y in np.vstack(points)})
    assert occupied_cells(records, true_poses, FORWARD) == expected
    wrong = true_poses + [[0.0, 0.0, 0.0], [-0.03, 0.0, 0.0]]  # the second scan placed 3 cm short
    assert occupied_cells(records, wrong, FORWARD) > expected


def test_path_extent_is_the_bounding_box_diagonal():
    assert path_extent(np.array([[0.0, 0.0, 1.0], [3.0, 0.0, 0.0], [1.0, 4.0, 2.0]])) == pytest.approx(5.0)
    assert path_extent(np.empty((0, 3))) == 0.0


def test_dead_reckoning_leaves_the_glitch_out():
    lines = [scan_line(0.0, wall_ranges(0.0)), odometry_line(0.1, 0.015), odometry_line(0.2, -0.12)]
    lines += [scan_line(0.3, wall_ranges(0.015))]
    run = LoadedRun(Path("hand-built.log"), course_log(lines), FORWARD, "test", np.zeros(3))
    truth = np.array([[0.0, 0.0, 0.0], [0.015, 0.0, 0.0], [0.015, 0.0, 0.0], [0.015, 0.0, 0.0]])
    sharp = map_sharpness(run, truth, jump_tolerance=0.02)
    # Without the -0.12 m glitch dead reckoning is the truth: the same cells, the same extent.
    assert sharp.cells == sharp.dead_reckoning_cells
    assert sharp.ratio == 1.0 and sharp.extent_ratio == pytest.approx(1.0)
    with_glitch = map_sharpness(run, truth)  # no tolerance: the glitch moves dead reckoning back
    assert with_glitch.dead_reckoning_cells > with_glitch.cells


def test_without_odometry_the_path_is_described_on_its_own():
    sharp = Sharpness(cells=120, dead_reckoning_cells=100, extent_m=12.5, dead_reckoning_extent_m=0.0)
    assert sharp.extent_ratio is None and sharp.to_dict()["extent_ratio"] is None
    assert sharp.describe("best") == (
        "  best: 120 occupied 1 cm cells, path extent 12.50 m (dead reckoning stands still, as on a log without "
        "odometry: nothing to compare with)"
    )
    assert Sharpness(120, 100, 12.5, 10.0).describe("best") == (
        "  best: 120 occupied 1 cm cells against dead reckoning's 100 (x1.20; fewer = sharper walls), "
        "path extent x1.25 of dead reckoning's"
    )
