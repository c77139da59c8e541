"""Trajectory and map metrics: hand-computed cases, and evo (the reference tool) on the same data."""

import numpy as np
import pytest

from mazeslam.data import sidecars
from mazeslam.evaluation.metrics import (
    absolute_trajectory_error,
    align_se2,
    apply_se2,
    map_error,
    normalized_estimation_error,
    relative_pose_error,
)


def wandering_path(count=200, seed=0):
    rng = np.random.default_rng(seed)
    theta = np.cumsum(rng.normal(0, 0.05, count))
    steps = 0.01 + 0.005 * rng.random(count)
    x = np.cumsum(steps * np.cos(theta))
    y = np.cumsum(steps * np.sin(theta))
    return np.column_stack([x, y, np.angle(np.exp(1j * theta))])


def test_ate_of_a_shifted_path_and_its_alignment():
    truth = wandering_path()
    shifted = apply_se2(np.array([0.3, -0.2, 0.4]), truth)
    assert absolute_trajectory_error(shifted, truth)["rmse"] > 0.2
    assert absolute_trajectory_error(shifted, truth, align=True)["rmse"] == pytest.approx(0.0, abs=1e-12)
    # The alignment found is the inverse of the shift: moving the shifted path back onto the truth.
    np.testing.assert_allclose(apply_se2(align_se2(shifted, truth), shifted), truth, atol=1e-12)
    assert align_se2(shifted, truth)[2] == pytest.approx(-0.4)


def test_ate_hand_computed():
    truth = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    estimate = np.array([[0.0, 0.3, 0.0], [1.0, -0.4, 0.0]])
    result = absolute_trajectory_error(estimate, truth)
    assert result["rmse"] == pytest.approx(np.sqrt((0.09 + 0.16) / 2))
    assert result["max"] == pytest.approx(0.4) and result["mean"] == pytest.approx(0.35)


def test_rpe_of_a_path_with_one_heading_error():
    truth = np.array([[k * 0.1, 0.0, 0.0] for k in range(11)])
    estimate = truth.copy()
    estimate[5:, 2] += 0.1  # from record 5 on the estimate thinks it is turned 0.1 rad
    result = relative_pose_error(estimate, truth, delta=5, unit="records")
    assert result["pairs"] == 2
    # Stretch 0 -> 5: the right 0.5 m, but it ends turned by 0.1 rad. Stretch 5 -> 10: no turn, but 0.5 m
    # along world x is, in its turned frame, 0.5 m at -0.1 rad: off the true motion by (0.5 (1 - cos 0.1), 0.5 sin 0.1).
    assert result["rot_rmse"] == pytest.approx(np.sqrt(0.1**2 / 2))
    assert result["trans_max"] == pytest.approx(np.hypot(0.5 * (1 - np.cos(0.1)), 0.5 * np.sin(0.1)))


def test_map_error_is_one_to_one():
    truth = np.array([[0.0, 0.0], [1.0, 0.0]])
    estimate = np.array([[0.01, 0.0], [0.02, 0.0], [1.0, 0.03]])  # two claim the first corner
    result = map_error(estimate, truth, match_radius=0.05)
    assert result["matched"] == 2
    assert result["precision"] == pytest.approx(2 / 3) and result["recall"] == 1.0
    assert result["rmse"] == pytest.approx(np.sqrt((0.01**2 + 0.03**2) / 2))


def test_nees_of_a_known_gaussian():
    rng = np.random.default_rng(2)
    covariance = np.diag([0.01, 0.04, 0.001])
    truth = np.zeros((20000, 3))
    estimate = rng.multivariate_normal(np.zeros(3), covariance, size=20000)
    nees = normalized_estimation_error(estimate, np.broadcast_to(covariance, (20000, 3, 3)), truth)
    assert nees.mean() == pytest.approx(3.0, rel=0.03)


def test_tum_export(tmp_path):
    path = tmp_path / "t.tum"
    sidecars.write_tum(path, np.array([1.0, 2.0]), np.array([[1.0, 2.0, np.pi / 2], [0.0, 0.0, 0.0]]))
    rows = np.loadtxt(path)
    np.testing.assert_allclose(rows[0], [1, 1, 2, 0, 0, 0, np.sin(np.pi / 4), np.cos(np.pi / 4)])


def test_agrees_with_evo_on_the_same_trajectories():
    evo_trajectory = pytest.importorskip("evo.core.trajectory", reason="evo (a dev dependency) is not installed")
    from evo.core import metrics as evo_metrics

    truth = wandering_path(400, seed=3)
    rng = np.random.default_rng(4)
    estimate = apply_se2(np.array([0.05, 0.02, 0.03]), truth)
    estimate[:, :2] += np.cumsum(rng.normal(0, 0.001, (400, 2)), axis=0)
    estimate[:, 2] += np.cumsum(rng.normal(0, 0.002, 400))
    times = np.arange(400, dtype=float)

    def to_evo(poses):
        half = poses[:, 2] / 2
        quaternions = np.column_stack([np.cos(half), np.zeros(len(poses)), np.zeros(len(poses)), np.sin(half)])
        xyz = np.column_stack([poses[:, 0], poses[:, 1], np.zeros(len(poses))])
        return evo_trajectory.PoseTrajectory3D(xyz, quaternions, times)  # quaternions w, x, y, z

    reference, estimated = to_evo(truth), to_evo(estimate)
    ape = evo_metrics.APE(evo_metrics.PoseRelation.translation_part)
    ape.process_data((reference, estimated))
    assert absolute_trajectory_error(estimate, truth)["rmse"] == pytest.approx(
        ape.get_statistic(evo_metrics.StatisticsType.rmse), rel=1e-9
    )
    aligned = to_evo(estimate)
    aligned.align(reference, correct_scale=False)
    ape.process_data((reference, aligned))
    assert absolute_trajectory_error(estimate, truth, align=True)["rmse"] == pytest.approx(
        ape.get_statistic(evo_metrics.StatisticsType.rmse), rel=1e-6
    )
    for delta, unit, evo_unit in ((0.2, "m", evo_metrics.Unit.meters), (25, "records", evo_metrics.Unit.frames)):
        for relation, key in (
            (evo_metrics.PoseRelation.translation_part, "trans_rmse"),
            (evo_metrics.PoseRelation.rotation_angle_rad, "rot_rmse"),
        ):
            rpe = evo_metrics.RPE(
                relation, delta=delta, delta_unit=evo_unit, all_pairs=False, pairs_from_reference=True
            )  # ours cuts the true path into stretches
            rpe.process_data((reference, estimated))
            ours = relative_pose_error(estimate, truth, delta, unit)[key]
            assert ours == pytest.approx(rpe.get_statistic(evo_metrics.StatisticsType.rmse), rel=1e-6), (unit, key)
