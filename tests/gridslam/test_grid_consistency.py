"""Is the grid filter's stated uncertainty right: the motion NIS by hand and the spread of the first
scan's draw (the pose NEES on the simulated building: test_grid_slam.py)."""

import numpy as np
import pytest

from mazeslam.gridslam import GridSlam, GridSlamParams
from mazeslam.gridslam.filter import GridDivergence, ScanSensor, motion_nis

BEARINGS = np.radians([-30.0, 0.0, 30.0])


def test_motion_nis_is_the_matchs_squared_distance_from_the_prediction_under_the_motion_noise():
    covariance = np.diag([0.01, 0.04, 0.0001])
    predicted = np.array([1.0, 2.0, np.pi - 0.01])
    matched = np.array([1.1, 1.8, -np.pi + 0.01])  # 0.02 rad on, across the +-pi seam
    assert motion_nis(matched, predicted, covariance) == pytest.approx(0.1**2 / 0.01 + 0.2**2 / 0.04 + 0.02**2 / 0.0001)


def first_scan(particles: int, motion) -> GridSlam:
    """A cloud that has processed one scan (three returns at 1 m) after ``motion`` from (1, 1, 0)."""
    slam = GridSlam(
        GridSlamParams(particles=particles, seed=3), np.array([1.0, 1.0, 0.0]), ScanSensor(BEARINGS, np.zeros(2))
    )
    update = slam.process(np.ones(3), np.asarray(motion, dtype=float))
    assert update.matched == 0.0 and np.isnan(update.nis)  # nothing to match the first scan against
    return slam


def test_the_first_scan_keeps_a_known_start_when_the_robot_has_not_moved():
    slam = first_scan(50, [0.0, 0.0, 0.0])
    assert np.array_equal(slam.poses, np.tile([1.0, 1.0, 0.0], (50, 1)))  # the floor would spread them


def test_the_first_scan_spreads_the_particles_by_the_motion_noise_of_the_motion_before_it():
    motion = np.array([0.5, 0.0, 0.2])
    slam = first_scan(1500, motion)
    stated = GridSlamParams().motion_noise.relative_covariance(motion)  # world = robot frame at heading 0
    spread = np.cov(slam.poses.T)
    assert np.allclose(slam.poses.mean(axis=0), [1.5, 1.0, 0.2], atol=0.01)
    assert np.allclose(np.diag(spread) / np.diag(stated), 1.0, atol=0.15)


def test_a_motion_that_is_not_finite_is_reported_as_divergence_in_words():
    slam = first_scan(particles=4, motion=np.zeros(3))
    with pytest.raises(GridDivergence, match="diverged: 4 of 4 particles' poses .* check the log's odometry"):
        slam.process(np.full(len(slam.sensor.bearings), 2.0), np.array([np.nan, 0.0, 0.0]))
