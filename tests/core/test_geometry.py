import numpy as np
import pytest

from mazeslam.core.geometry import (
    advance_pose,
    cartesian_to_polar,
    compose,
    inverse,
    polar_to_cartesian,
    relative,
    transform_points,
    wrap_angle,
)


def test_wrap_angle_maps_to_half_open_interval():
    assert wrap_angle(np.pi) == pytest.approx(np.pi)
    assert wrap_angle(-np.pi) == pytest.approx(np.pi)
    assert wrap_angle(3 * np.pi / 2) == pytest.approx(-np.pi / 2)
    assert wrap_angle(-5 * np.pi / 2) == pytest.approx(-np.pi / 2)
    np.testing.assert_allclose(wrap_angle(np.array([0.1, 2 * np.pi + 0.1])), [0.1, 0.1])


def test_compose_hand_computed():
    # Robot at (1, 2) facing +y; a point 1 m ahead and 0.5 m to its left is at (0.5, 3).
    a = np.array([1.0, 2.0, np.pi / 2])
    b = np.array([1.0, 0.5, np.pi / 2])
    np.testing.assert_allclose(compose(a, b), [0.5, 3.0, np.pi], atol=1e-12)


def test_inverse_and_relative_round_trip():
    rng = np.random.default_rng(1)
    a = np.column_stack([rng.normal(size=(50, 2)), rng.uniform(-np.pi, np.pi, 50)])
    b = np.column_stack([rng.normal(size=(50, 2)), rng.uniform(-np.pi, np.pi, 50)])
    identity = compose(a, inverse(a))
    np.testing.assert_allclose(identity[:, :2], 0, atol=1e-12)
    np.testing.assert_allclose(np.sin(identity[:, 2]), 0, atol=1e-12)
    np.testing.assert_allclose(compose(a, relative(a, b)), b, atol=1e-12)


def test_advance_pose_straight_turn_and_arc():
    np.testing.assert_allclose(advance_pose([0, 0, 0], 1.0, 0.0), [1, 0, 0])
    np.testing.assert_allclose(advance_pose([1, 1, np.pi / 2], 0.0, 0.3), [1, 1, np.pi / 2 + 0.3])
    # A quarter circle of radius R split into many increments ends at (R, R) facing +y.
    radius, steps = 0.5, 2000
    pose = np.zeros(3)
    arc = np.pi / 2 * radius
    for _ in range(steps):
        pose = advance_pose(pose, arc / steps, (np.pi / 2) / steps)
    np.testing.assert_allclose(pose, [radius, radius, np.pi / 2], atol=1e-7)


def test_advance_pose_broadcasts_over_particles():
    poses = np.zeros((4, 3))
    moved = advance_pose(poses, np.array([0.0, 1.0, 2.0, 3.0]), 0.0)
    np.testing.assert_allclose(moved[:, 0], [0, 1, 2, 3])


def test_polar_cartesian_round_trip():
    points = polar_to_cartesian([1.0, 2.0], [0.0, np.pi / 2])
    np.testing.assert_allclose(points, [[1, 0], [0, 2]], atol=1e-12)
    ranges, bearings = cartesian_to_polar(points)
    np.testing.assert_allclose(ranges, [1, 2])
    np.testing.assert_allclose(bearings, [0, np.pi / 2])


def test_transform_points_hand_computed():
    np.testing.assert_allclose(transform_points([1, 0, np.pi / 2], [[1.0, 0.0]]), [[1, 1]], atol=1e-12)
