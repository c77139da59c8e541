"""FastSLAM 2.0's motion covariance (``ObservationProposal.predict`` and ``predict_relative``, and
``proposals._through_heading``) against the explicit products F Sigma F^T + V Q V^T, with the
Jacobians written out by hand here and checked against finite differences of the motion itself."""

import math

import numpy as np
import pytest

from mazeslam.core.geometry import advance_pose, compose
from mazeslam.core.motion import OdometryNoise
from mazeslam.fastslam import ekf
from mazeslam.fastslam.proposals import ObservationProposal, _through_heading

NOISE = OdometryNoise(0.05, 0.1, 0.2)
#: Particle counts on both sides of ``ekf.ENTRYWISE_FROM`` (``ekf.congruence``'s two ways).
COUNTS = [1, 7, ekf.ENTRYWISE_FROM + 3]


def random_poses(rng: np.random.Generator, count: int) -> np.ndarray:
    return np.column_stack([rng.normal(size=(count, 2)), rng.uniform(-math.pi, math.pi, count)])


def random_covariances(rng: np.random.Generator, count: int) -> np.ndarray:
    """(count, 3, 3) symmetric positive definite, all entries non-zero."""
    root = rng.normal(size=(count, 3, 3))
    return root @ root.transpose(0, 2, 1) + 0.1 * np.eye(3)


def advance_jacobians(pose: np.ndarray, distance: float, turn: float) -> tuple[np.ndarray, np.ndarray]:
    """d advance_pose / d pose (3, 3) and / d (distance, turn) (3, 2) at one pose, by hand: the
    robot moves ``distance`` along heading h = theta + turn / 2."""
    h = pose[2] + 0.5 * turn
    f = np.array([[1, 0, -distance * math.sin(h)], [0, 1, distance * math.cos(h)], [0, 0, 1]])
    v = np.array([[math.cos(h), -0.5 * distance * math.sin(h)], [math.sin(h), 0.5 * distance * math.cos(h)], [0, 1]])
    return f, v


def compose_jacobians(pose: np.ndarray, increment: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """d compose(pose, increment) / d pose and / d increment (3, 3 each) at one pose, by hand."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    dx, dy = increment[0], increment[1]
    f = np.array([[1, 0, -s * dx - c * dy], [0, 1, c * dx - s * dy], [0, 0, 1]])
    v = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    return f, v


def numeric_jacobian(function, at: np.ndarray, step: float = 1e-6) -> np.ndarray:
    """Central differences of ``function`` (an array of 3) at ``at`` (n,): (3, n)."""
    columns = []
    for i in range(len(at)):
        delta = np.zeros(len(at))
        delta[i] = step
        columns.append((function(at + delta) - function(at - delta)) / (2 * step))
    return np.column_stack(columns)


@pytest.mark.parametrize("seed", range(4))
def test_the_hand_written_jacobians_are_the_motions_derivatives(seed):
    rng = np.random.default_rng(seed)
    pose, distance, turn = random_poses(rng, 1)[0], rng.uniform(-0.3, 0.3), rng.uniform(-0.5, 0.5)
    increment = rng.normal(0, 0.2, 3)
    f, v = advance_jacobians(pose, distance, turn)
    np.testing.assert_allclose(numeric_jacobian(lambda p: advance_pose(p, distance, turn), pose), f, atol=1e-8)
    np.testing.assert_allclose(
        numeric_jacobian(lambda u: advance_pose(pose, u[0], u[1]), np.array([distance, turn])), v, atol=1e-8
    )
    f, v = compose_jacobians(pose, increment)
    np.testing.assert_allclose(numeric_jacobian(lambda p: compose(p, increment), pose), f, atol=1e-8)
    np.testing.assert_allclose(numeric_jacobian(lambda u: compose(pose, u), increment), v, atol=1e-8)


@pytest.mark.parametrize("count", COUNTS)
def test_through_heading_is_f_sigma_f_transposed(count):
    rng = np.random.default_rng(count)
    sigma = random_covariances(rng, count)
    f02, f12 = rng.normal(size=count), rng.normal(size=count)
    f = np.tile(np.eye(3), (count, 1, 1))
    f[:, 0, 2], f[:, 1, 2] = f02, f12
    np.testing.assert_allclose(_through_heading(sigma, f02, f12), f @ sigma @ f.transpose(0, 2, 1), rtol=1e-12)


@pytest.mark.parametrize("count", COUNTS)
@pytest.mark.parametrize("distance, turn", [(0.2, 0.3), (-0.15, -0.4), (0.25, 0.0), (0.0, 0.5)])
def test_predict_propagates_the_covariance_through_the_odometry_jacobians(count, distance, turn):
    rng = np.random.default_rng(100 + count)
    poses, sigma = random_poses(rng, count), random_covariances(rng, count)
    means, carried = ObservationProposal().predict(poses, sigma, distance, turn, NOISE, rng)
    q = np.diag([0.05**2 * abs(distance), 0.1**2 * abs(turn) + 0.2**2 * abs(distance)])  # (distance, turn)
    for pose, prior, mean, covariance in zip(poses, sigma, means, carried):
        f, v = advance_jacobians(pose, distance, turn)
        np.testing.assert_allclose(covariance, f @ prior @ f.T + v @ q @ v.T, rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(mean, advance_pose(pose, distance, turn), rtol=0, atol=1e-15)


def test_predict_without_motion_leaves_the_particles_as_they_are():
    rng = np.random.default_rng(2)
    poses, sigma = random_poses(rng, 5), random_covariances(rng, 5)
    means, carried = ObservationProposal().predict(poses, sigma, 0.0, 0.0, NOISE, rng)
    np.testing.assert_array_equal(means, poses)
    np.testing.assert_array_equal(carried, sigma)


@pytest.mark.parametrize("count", COUNTS)
def test_predict_relative_propagates_the_covariance_through_the_composition_jacobians(count):
    rng = np.random.default_rng(200 + count)
    poses, sigma = random_poses(rng, count), random_covariances(rng, count)
    increment = np.array([0.12, -0.05, 0.3])
    covariance = random_covariances(rng, 1)[0] * 1e-3  # full (3, 3), not only the diagonal the filter uses
    means, carried = ObservationProposal().predict_relative(poses, sigma, increment, covariance, rng)
    for pose, prior, mean, propagated in zip(poses, sigma, means, carried):
        f, v = compose_jacobians(pose, increment)
        np.testing.assert_allclose(propagated, f @ prior @ f.T + v @ covariance @ v.T, rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(mean, compose(pose, increment), rtol=0, atol=1e-15)
