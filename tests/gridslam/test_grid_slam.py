"""The grid filter on a simulated building: a ring of corridors driven round more than once with
biased wheel odometry; the filter must close the loop with a map that matches the walls."""

import numpy as np
import pytest

from mazeslam.core.config import from_mapping
from mazeslam.core.geometry import advance_pose, compose, relative
from mazeslam.core.motion import dead_reckoning
from mazeslam.data import log
from mazeslam.data.log import read
from mazeslam.data.map_io import OCCUPIED
from mazeslam.evaluation.metrics import absolute_trajectory_error, align_se2, apply_se2, normalized_estimation_error
from mazeslam.gridslam import GridSlamParams, run_grid_slam
from mazeslam.gridslam.filter import odometry_at_record_times, scan_motions
from mazeslam.gridslam.occupancy import grid_states
from mazeslam.sim.building import building_walls, simulate_building_log


@pytest.fixture(scope="module")
def building(tmp_path_factory):
    simulated = simulate_building_log(tmp_path_factory.mktemp("grid") / "building.log")
    course_log = read(simulated.path)
    result = run_grid_slam(course_log, simulated.geometry, simulated.start_pose, GridSlamParams(particles=8))
    return simulated, course_log, result


def distance_to_walls(points: np.ndarray, walls: np.ndarray) -> np.ndarray:
    """Distance (M,) from each of ``points`` (M, 2) to the nearest wall segment (W, 4), m."""
    start, vector = walls[:, :2], walls[:, 2:] - walls[:, :2]
    along = np.einsum("mwi,wi->mw", points[:, None] - start, vector) / np.einsum("wi,wi->w", vector, vector)
    nearest = start + np.clip(along, 0, 1)[..., None] * vector
    return np.hypot(*(points[:, None] - nearest).transpose(2, 0, 1)).min(axis=1)


def test_the_filter_closes_the_loop_where_dead_reckoning_does_not(building):
    simulated, course_log, result = building
    truth = simulated.truth[result.scan_records]
    drift = dead_reckoning(course_log, simulated.start_pose)[result.scan_records]
    assert np.hypot(*(drift[-1, :2] - truth[-1, :2])) > 2.0  # the odometry alone misses the start by metres
    assert np.hypot(*(result.best_poses[-1, :2] - truth[-1, :2])) < 0.25
    assert absolute_trajectory_error(result.best_poses, truth, align=True)["rmse"] < 0.1
    assert np.nanmean(result.matched) > 0.95


def test_the_best_map_lies_on_the_walls(building):
    simulated, _, result = building
    occupancy = grid_states(result.grid)
    cells = np.argwhere(occupancy.states == OCCUPIED)
    centres = occupancy.origin[:2] + (cells + 0.5) * occupancy.resolution
    # the map's frame is the filter's: moved onto the world's as its path is onto the true one
    centres = apply_se2(align_se2(result.best_poses, simulated.truth[result.scan_records]), centres)
    assert len(centres) > 500
    assert np.mean(distance_to_walls(centres, building_walls()) < 0.1) > 0.9  # cells are 0.05 m


def test_the_trajectory_has_a_row_per_record(building):
    simulated, course_log, result = building
    poses, covariances = result.record_trajectory()
    assert poses.shape == (len(course_log), 3) and covariances.shape == (len(course_log), 3, 3)
    np.testing.assert_allclose(poses[result.scan_records], result.best_poses)
    reckoned = dead_reckoning(course_log, simulated.start_pose)
    first = result.scan_records[0]
    np.testing.assert_allclose(poses[:first], reckoned[:first])  # before the first scan: the odometry from the start
    between = result.scan_records[1] - 1  # the record before the second scan: the first scan's pose moved on
    assert between > first
    moved_on = compose(result.best_poses[0], relative(reckoned[first], reckoned[between]))
    np.testing.assert_allclose(poses[between], moved_on, atol=1e-12)
    assert result.processed[0] and result.processed.sum() < len(result.processed) + 1


def test_the_settings_load_from_a_toml_section_and_the_wheels_give_the_motion(building):
    simulated, course_log, _ = building
    params = from_mapping(
        GridSlamParams,
        {"particles": 5, "motion": "wheels", "grid": {"resolution": 0.1}, "laser_odometry": {"enabled": True}},
        "[grid]",
    )
    assert params.grid.resolution == 0.1 and params.laser_odometry.enabled
    motions = scan_motions(course_log, simulated.geometry, params, simulated.start_pose)
    chained = dead_reckoning(course_log, simulated.start_pose)[np.flatnonzero(course_log.is_scan)]
    np.testing.assert_allclose(relative(chained[:-1], chained[1:]), motions[1:], atol=1e-9)


def test_a_scan_between_odometry_records_gets_the_share_of_the_motion_its_time_says():
    # Odometry at 0.2 s and 0.4 s (each 0.02 m and 0.1 rad), a scan at 0.35 s: three quarters of
    # the way through the second record's motion.
    text = "0.2 0 0.02 0.1 -1 -1\n0.35 1 0.5 0.5 0.5 0.5\n0.4 0 0.02 0.1 -1 -1\n"
    course_log = log.parse(text)
    poses = odometry_at_record_times(course_log, (1.0, 2.0, 0.0))
    first = advance_pose(np.array([1.0, 2.0, 0.0]), 0.02, 0.1)
    np.testing.assert_allclose(poses[0], first)
    np.testing.assert_allclose(poses[1], advance_pose(first, 0.015, 0.075))
    np.testing.assert_allclose(poses[2], advance_pose(first, 0.02, 0.1))


def test_the_mean_paths_pose_nees_is_consistent_on_the_simulated_building(building):
    simulated, _, result = building
    truth = simulated.truth[result.scan_records]
    nees = normalized_estimation_error(result.mean_poses, result.covariances, truth)
    # chi-square with 3 degrees of freedom: median 2.37; the filter stated 17-40 before its first
    # motion was drawn with noise (the whole map then turned with that motion's heading error)
    assert 1.0 < np.nanmedian(nees) < 6.0
    assert np.isfinite(result.nis[result.processed][1:]).mean() > 0.9  # every matched scan has a NIS
