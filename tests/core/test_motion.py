import numpy as np
import pytest

from mazeslam.core.motion import OdometryNoise, predict_odometry, predict_relative


def test_standing_still_moves_no_particle():
    poses = np.random.default_rng(0).normal(size=(50, 3))
    moved = predict_odometry(poses, 0.0, 0.0, OdometryNoise(0.01, 0.05, 0.1), np.random.default_rng(1))
    np.testing.assert_array_equal(moved, poses)  # the exercise's model would spread them


def test_noise_grows_with_the_motion():
    rng = np.random.default_rng(2)
    start = np.zeros((20000, 3))
    sigma_x, sigma_th, sigma_drive = 0.01, 0.05, 0.1
    for distance in (0.01, 0.16):
        moved = predict_odometry(start, distance, 0.0, OdometryNoise(sigma_x, sigma_th, sigma_drive), rng)
        # Along x: distance noise sigma_x sqrt(d) (the heading noise changes x only to second order).
        assert moved[:, 0].std() == pytest.approx(sigma_x * np.sqrt(distance), rel=0.05)
        assert moved[:, 2].std() == pytest.approx(sigma_drive * np.sqrt(distance), rel=0.05)
    turned = predict_odometry(start, 0.0, 0.5, OdometryNoise(sigma_x, sigma_th, sigma_drive), rng)
    assert turned[:, 2].mean() == pytest.approx(0.5, abs=1e-3)
    assert turned[:, 2].std() == pytest.approx(sigma_th * np.sqrt(0.5), rel=0.05)
    np.testing.assert_allclose(turned[:, :2], 0.0, atol=1e-12)  # turning on the spot does not translate


def test_mean_motion_follows_the_odometry():
    rng = np.random.default_rng(3)
    start = np.tile([1.0, 2.0, np.pi / 2], (20000, 1))
    moved = predict_odometry(start, 0.1, 0.0, OdometryNoise(0.005, 0.03, 0.12), rng)
    assert moved[:, 0].mean() == pytest.approx(1.0, abs=2e-4)
    assert moved[:, 1].mean() == pytest.approx(2.1, abs=2e-4)


def test_relative_motion_covariance_in_the_filters_units():
    covariance = OdometryNoise(0.1, 0.2, 0.05).relative_covariance(np.array([3.0, 4.0, -0.5]))
    # d = 5 m: position 0.1^2 * 5 along and across; heading 0.2^2 * 0.5 + 0.05^2 * 5
    assert np.diag(covariance) == pytest.approx([0.05, 0.05, 0.02 + 0.0125])
    assert np.count_nonzero(covariance - np.diag(np.diag(covariance))) == 0


def test_relative_prediction_spreads_as_its_covariance_in_the_robot_frame():
    rng = np.random.default_rng(1)
    start = np.tile([1.0, 2.0, np.pi / 2], (20000, 1))  # facing +y: the robot's x is the world's y
    covariance = np.diag([0.04, 0.01, 0.0025])
    moved = predict_relative(start, np.array([1.0, 0.0, 0.0]), covariance, rng)
    assert moved[:, 1].mean() == pytest.approx(3.0, abs=0.005)
    assert moved[:, 1].std() == pytest.approx(0.2, rel=0.03)  # along the heading
    assert moved[:, 0].std() == pytest.approx(0.1, rel=0.03)  # across it
    assert moved[:, 2].std() == pytest.approx(0.05, rel=0.03)
