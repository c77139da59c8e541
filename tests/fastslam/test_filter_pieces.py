"""The pure functions FastSLAM is built of, each against a hand-computed case."""

import math

import numpy as np
import pytest

from mazeslam.core.motion import OdometryNoise
from mazeslam.core.resampling import effective_sample_size, normalized_weights, systematic_resample
from mazeslam.fastslam import ekf
from mazeslam.fastslam.association import associate_greedy, associate_known
from mazeslam.fastslam.proposals import MotionProposal, ObservationProposal


def test_ekf_update_of_a_scalar_is_the_weighted_average():
    # Prior N(1, 4), measurement 3 with variance 1 of the state itself: posterior mean 1 + 4/5 * 2, variance 4/5.
    mean, covariance, s = ekf.update(
        np.array([[1.0]]), np.array([[[4.0]]]), np.array([[2.0]]), np.array([[[1.0]]]), np.array([[1.0]])
    )
    assert mean[0, 0] == pytest.approx(2.6)
    assert covariance[0, 0, 0] == pytest.approx(0.8)
    assert s[0, 0, 0] == pytest.approx(5.0)


@pytest.mark.parametrize("per_particle", [False, True], ids=["shared noise", "per-particle noise"])
@pytest.mark.parametrize("state, observed", [(2, 2), (3, 2), (2, 1)])
def test_ekf_update_entry_by_entry_equals_the_batched_matmul(state, observed, per_particle):
    rng = np.random.default_rng(state + observed)
    n = ekf.ENTRYWISE_FROM
    root = rng.normal(size=(n, state, state))
    covariance = root @ np.swapaxes(root, 1, 2) + np.eye(state)
    arguments = (rng.normal(size=(n, state)), covariance, rng.normal(size=(n, observed)))
    jacobian, noise = rng.normal(size=(n, observed, state)), np.eye(observed) * 0.1
    if per_particle:  # R (n, k, k), each its own (as proposals.draw hands it a landmark's covariance plus R)
        noise_root = rng.normal(size=(n, observed, observed))
        noise = 0.1 * noise_root @ np.swapaxes(noise_root, 1, 2) + 0.01 * np.eye(observed)
    updated = ekf.update(*arguments, jacobian, noise)
    for entrywise, batched in zip(updated, ekf._update_batched(*arguments, jacobian, noise)):
        np.testing.assert_allclose(entrywise, batched, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(updated[2], jacobian @ covariance @ np.swapaxes(jacobian, 1, 2) + noise, rtol=1e-12)
    np.testing.assert_allclose(
        ekf.congruence(covariance, jacobian), jacobian @ covariance @ np.swapaxes(jacobian, 1, 2)
    )


def test_range_bearing_jacobians_match_finite_differences():
    rng = np.random.default_rng(0)
    poses = rng.normal(size=(5, 3))
    landmarks = poses[:, :2] + rng.uniform(0.2, 1.0, (5, 2))
    z_hat, h_landmark, h_pose = ekf.range_bearing(poses, landmarks)
    step = 1e-7
    for axis in range(3):
        moved = poses.copy()
        moved[:, axis] += step
        numeric = ekf.innovation(ekf.range_bearing(moved, landmarks)[0], z_hat) / step
        np.testing.assert_allclose(numeric, h_pose[:, :, axis], atol=1e-5)
    for axis in range(2):
        moved = landmarks.copy()
        moved[:, axis] += step
        numeric = ekf.innovation(ekf.range_bearing(poses, moved)[0], z_hat) / step
        np.testing.assert_allclose(numeric, h_landmark[:, :, axis], atol=1e-5)


def test_weights_and_effective_sample_size():
    weights = normalized_weights(np.log(np.array([1.0, 1.0, 2.0])) - 1000.0)  # underflow-proof
    np.testing.assert_allclose(weights, [0.25, 0.25, 0.5])
    assert effective_sample_size(weights) == pytest.approx(1 / (0.0625 * 2 + 0.25))
    assert effective_sample_size(np.full(4, 0.25)) == pytest.approx(4.0)


def test_systematic_resampling_keeps_each_particle_in_proportion_to_its_weight():
    weights = np.array([0.5, 0.25, 0.125, 0.125])
    counts = np.bincount(systematic_resample(weights, np.random.default_rng(3)), minlength=4)
    # Systematic resampling gives each particle floor(P w) or ceil(P w) copies: here exactly 2, 1, 0-1, 0-1.
    assert counts[0] == 2 and counts[1] == 1 and counts.sum() == 4


def test_greedy_association_is_one_to_one_and_gated():
    inf = np.inf
    # Two observations both nearest to slot 0; the closer takes it, the other falls back to slot 1.
    distance2 = np.array([[[1.0, 5.0], [0.5, 3.0]]])
    np.testing.assert_array_equal(associate_greedy(distance2, gate=9.0), [[1, 0]])
    # Beyond the gate: unmatched.
    np.testing.assert_array_equal(associate_greedy(np.array([[[10.0, inf]]]), gate=9.0), [[-1]])


def test_known_association_finds_the_slot_of_each_identity():
    slot_ids = np.array([[7, 3, -1], [3, 7, 5]])
    exists = np.array([[True, True, False], [True, True, True]])
    assigned = associate_known(np.array([3, 5, -1]), slot_ids, exists)
    np.testing.assert_array_equal(assigned, [[1, -1, -1], [0, 2, -1]])


def test_the_observation_proposal_draws_from_the_corrected_motion_gaussian():
    # A pose known to 0.1 m in x and y sees a landmark known exactly; the draw must be pulled to
    # where the observation puts the robot, and its spread shrunk below the motion's.
    count = 4000
    poses = np.tile([0.05, 0.0, 0.0], (count, 1))
    covariances = np.tile(np.diag([0.01, 0.01, 1e-6]), (count, 1, 1))
    landmark = np.array([1.0, 0.0])
    observation = np.array([[1.0, 0.0]])  # seen 1 m straight ahead: the robot is at the origin
    drawn, carried, (distance2, _) = ObservationProposal().draw(
        poses,
        covariances,
        np.zeros((count, 1), dtype=int),
        observation,
        np.tile(landmark, (count, 1, 1)),
        np.zeros((count, 1, 2, 2)),
        np.array([np.diag([1e-4, 1e-4])]),
        np.random.default_rng(5),
    )
    # Along x: prior variance 0.01, measurement variance 1e-4 -> posterior mean 0.05 * 1e-4 / 0.0101.
    assert drawn[:, 0].mean() == pytest.approx(0.05 * 1e-4 / 0.0101, abs=2e-4)
    assert drawn[:, 0].std() == pytest.approx(math.sqrt(0.01 * 1e-4 / 0.0101), rel=0.05)
    np.testing.assert_array_equal(carried, 0.0)
    # The weight's innovation: range 1 - 0.95 = 0.05 under variance 0.01 + 1e-4; bearing 0.
    np.testing.assert_allclose(distance2[:, 0], 0.05**2 / 0.0101)


def test_the_observation_proposal_weighs_by_the_joint_likelihood_of_the_scan():
    # Two observations share the pose's uncertainty: the product of their sequential predictive
    # densities must equal the joint Gaussian density of both, not the product of the marginals.
    pose, spread = np.array([[0.02, -0.01, 0.05]]), np.array([np.diag([4e-4, 1e-4, 4e-3])])
    landmarks = np.array([[[1.0, 0.2], [-0.3, 0.8]]])
    observations = np.array([[1.01, 0.13], [0.86, 1.93]])
    noise = np.array([np.diag([1e-4, 4e-4]), np.diag([2e-4, 1e-4])])
    _, _, (distance2, determinant) = ObservationProposal().draw(
        pose,
        spread,
        np.array([[0, 1]]),
        observations,
        landmarks,
        np.zeros((1, 2, 2, 2)),
        noise,
        np.random.default_rng(0),
    )
    sequential = -0.5 * (distance2 + np.log(determinant)).sum()
    z_hat, _, h_pose = ekf.range_bearing(np.repeat(pose, 2, axis=0), landmarks[0])
    g = h_pose.reshape(4, 3)
    joint_covariance = g @ spread[0] @ g.T + np.block([[noise[0], np.zeros((2, 2))], [np.zeros((2, 2)), noise[1]]])
    residual = ekf.innovation(observations, z_hat).reshape(4)
    joint = -0.5 * (residual @ np.linalg.solve(joint_covariance, residual) + np.log(np.linalg.det(joint_covariance)))
    # Equal up to the linearisation at the corrected pose (second order in the small corrections).
    assert sequential == pytest.approx(joint, abs=0.05)
    blocks = [slice(2 * k, 2 * k + 2) for k in range(2)]
    marginals = -0.5 * sum(
        residual[b] @ np.linalg.solve(joint_covariance[b, b], residual[b])
        + np.log(np.linalg.det(joint_covariance[b, b]))
        for b in blocks
    )
    assert abs(marginals - joint) > 10 * abs(sequential - joint)


def test_the_motion_proposal_draws_when_moving_and_carries_nothing():
    poses, covariances = np.zeros((2000, 3)), np.zeros((2000, 3, 3))
    moved, carried = MotionProposal().predict(
        poses, covariances, 0.25, 0.0, OdometryNoise(0.02, 0.0, 0.0), np.random.default_rng(1)
    )
    assert moved[:, 0].std() == pytest.approx(0.02 * 0.5, rel=0.05)
    np.testing.assert_array_equal(carried, 0.0)
    means, spread = ObservationProposal().predict(
        poses, covariances, 0.25, 0.0, OdometryNoise(0.02, 0.0, 0.0), np.random.default_rng(1)
    )
    np.testing.assert_allclose(means[:, 0], 0.25)
    assert spread[0, 0, 0] == pytest.approx(0.02**2 * 0.25)
