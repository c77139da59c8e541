"""The uncertainty a run states, and the statistics that judge it, against hand-computed cases."""

import dataclasses
import json
import math

import numpy as np
import pytest
from conftest import EXACT as NOISE_FREE

from mazeslam.data import sidecars
from mazeslam.evaluation.consistency import OBSERVATION_BOUND_95, POSE_BOUND_95, nees_summary, nis_summary
from mazeslam.evaluation.metrics import normalized_estimation_error
from mazeslam.fastslam.filter import FastSLAM, FastSLAMParams

#: The noise-free filter with 0.02 rad of bearing noise.
EXACT = dataclasses.replace(NOISE_FREE, sigmaB=0.02)


def test_the_pose_covariance_is_the_weighted_covariance_of_the_cloud():
    slam = FastSLAM(FastSLAMParams(NPARTICLES=3))
    slam.poses = np.array([[0.0, 0.0, 0.1], [1.0, 0.0, 0.1], [0.0, 2.0, 0.4]])
    slam.log_weights = np.log([0.5, 0.25, 0.25])
    # By hand: mean x = 0.25, y = 0.5; heading mean atan2(sum w sin, sum w cos) near 0.175.
    mean = slam.mean_pose()
    assert mean[:2] == pytest.approx([0.25, 0.5])
    heading = math.atan2(0.75 * math.sin(0.1) + 0.25 * math.sin(0.4), 0.75 * math.cos(0.1) + 0.25 * math.cos(0.4))
    assert mean[2] == pytest.approx(heading)
    dx, dy, dt = np.array([-0.25, 0.75, -0.25]), np.array([-0.5, -0.5, 1.5]), np.array([0.1, 0.1, 0.4]) - heading
    w = np.array([0.5, 0.25, 0.25])
    expected = np.array([[w @ (a * b) for b in (dx, dy, dt)] for a in (dx, dy, dt)])
    np.testing.assert_allclose(slam.pose_covariance(), expected, atol=1e-12)


def test_the_trajectory_file_round_trips_poses_and_covariances(tmp_path):
    rng = np.random.default_rng(0)
    roots = rng.normal(size=(4, 3, 3)) * 0.01
    covariances = roots @ np.swapaxes(roots, 1, 2)
    poses = rng.normal(size=(4, 3))
    sidecars.write_trajectory(tmp_path / "t.csv", np.arange(4) * 0.2, poses, covariances)
    assert (tmp_path / "t.csv").read_text().splitlines()[0] == (
        "t,x,y,theta,cov_xx,cov_xy,cov_xtheta,cov_yy,cov_ytheta,cov_thetatheta"
    )
    times, read_poses, read_covariances = sidecars.read_trajectory(tmp_path / "t.csv")
    np.testing.assert_allclose(times, np.arange(4) * 0.2)
    np.testing.assert_allclose(read_poses, poses, atol=1e-6)
    np.testing.assert_allclose(read_covariances, covariances, rtol=1e-8)


def test_nees_by_hand():
    # Error (0.1 m, 0, 0.2 rad) under a diagonal covariance (0.01, 1, 0.04): 1 + 0 + 1 = 2.
    nees = normalized_estimation_error(
        np.array([[1.1, 2.0, 0.2]]), np.diag([0.01, 1.0, 0.04])[None], np.array([[1.0, 2.0, 0.0]])
    )
    assert nees[0] == pytest.approx(2.0)
    # The heading error is wrapped: 3.1 vs -3.1 rad is 0.083 rad apart, not 6.2.
    wrapped = normalized_estimation_error(np.array([[0.0, 0.0, 3.1]]), np.eye(3)[None], np.array([[0.0, 0.0, -3.1]]))
    assert wrapped[0] == pytest.approx((2 * math.pi - 6.2) ** 2)


def test_nis_of_one_observation_by_hand():
    slam = FastSLAM(EXACT)
    slam.update(np.array([[1.0, 0.0]]))  # a landmark at (1, 0), covariance G R G^T = diag(1e-4, 4e-4)
    report = slam.update(np.array([[1.02, 0.01]]))
    # S = H Sigma H^T + R with H = I at (1, 0) from the origin: diag(2e-4, 8e-4); nu = (0.02, 0.01).
    assert report.nis == pytest.approx([0.02**2 / 2e-4 + 0.01**2 / 8e-4])


def test_summaries_give_mean_median_and_share_inside_the_bound():
    summary = nees_summary(np.array([1.0, 2.0, 10.0, np.nan]))
    assert summary == {"mean": pytest.approx(13 / 3), "median": 2.0, "inside_95": pytest.approx(2 / 3), "count": 3}
    assert POSE_BOUND_95 == pytest.approx(7.815, abs=1e-3) and OBSERVATION_BOUND_95 == pytest.approx(5.991, abs=1e-3)
    assert nis_summary(np.empty(0)) == {"mean": None, "median": None, "inside_95": None, "count": 0}


def test_the_slam_command_writes_strict_json_and_reports_consistency(default_run, tmp_path):
    from mazeslam.cli.slam import run_slam_command

    lines = run_slam_command(default_run.log_path, None, tmp_path / "out", {"NPARTICLES": 20}, progress=False)
    text = "\n".join(lines)
    assert "NIS of" in text and "pose NEES" in text

    def refuse(constant):
        raise ValueError(f"non-strict JSON constant {constant}")

    document = json.loads((tmp_path / "out" / "map.json").read_text(), parse_constant=refuse)
    assert document["nis"]["count"] > 0 and 0 <= document["nees"]["inside_95"] <= 1
    # NIS per kind of observation: every associated observation in exactly one kind.
    by_kind = document["nis_by_kind"]
    assert set(by_kind) <= {"corner", "wall_end"}
    assert sum(summary["count"] for summary in by_kind.values()) == document["nis"]["count"]
    if len(by_kind) > 1:
        assert "NIS mean by kind of observation" in text
    _, _, covariances = sidecars.read_trajectory(tmp_path / "out" / "trajectory.csv")
    assert np.all(np.linalg.eigvalsh(covariances[1:]) >= -1e-12)


def test_map_orientation_spread_recovers_turned_maps():
    from mazeslam.evaluation.consistency import map_orientation_spread

    square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    centre = square.mean(axis=0)

    def turned(angle, shift):
        c, s = math.cos(angle), math.sin(angle)
        return (square - centre) @ np.array([[c, s], [-s, c]]) + centre + shift

    # Three maps turned by -a, 0, +a (and shifted, which does not count), equal weights: sd = a sqrt(2/3).
    a = 0.02
    means = np.stack([turned(-a, [0.1, 0.0]), turned(0.0, [0.0, 0.0]), turned(a, [0.0, -0.2])])
    exists = np.ones((3, 4), dtype=bool)
    weights = np.full(3, 1 / 3)
    assert map_orientation_spread(means, exists, weights) == pytest.approx(a * math.sqrt(2 / 3), rel=1e-3)
    # One ancestor (identical maps): no spread; a slot some particle lacks is left out.
    same = np.stack([square] * 3)
    extra = np.concatenate([same, np.full((3, 1, 2), 5.0)], axis=1)
    holds = np.concatenate([exists, np.array([[True], [False], [True]])], axis=1)
    assert map_orientation_spread(extra, holds, weights) == pytest.approx(0.0, abs=1e-12)
    assert math.isnan(map_orientation_spread(same[:, :1], exists[:, :1], weights))


def test_nis_is_grouped_by_the_kind_of_observation(default_run):
    from mazeslam.data.loaded_run import load_run
    from mazeslam.pipeline import SlamConfig, run_slam

    run = load_run(default_run.log_path)
    result = run_slam(run, SlamConfig(), progress=False)
    groups = result.nis_by_kind()
    # Every NIS value lands in exactly one group, and the kinds are the corner extractor's fixed ones.
    assert sum(len(values) for values in groups.values()) == len(result.nis)
    assert set(groups) <= {"corner", "wall_end"} and len(groups["corner"]) > 0
    np.testing.assert_allclose(np.sort(np.concatenate(list(groups.values()))), np.sort(result.nis))


def test_nis_indexes_name_the_observation_they_belong_to():
    slam = FastSLAM(EXACT)
    slam.update(np.array([[1.0, 0.0]]))
    # A new observation first (no landmark yet), then the known one: only index 1 has a NIS.
    report = slam.update(np.array([[3.0, 1.5], [1.02, 0.01]]))
    assert report.nis_observations.tolist() == [1]
    assert report.nis == pytest.approx([0.02**2 / 2e-4 + 0.01**2 / 8e-4])


def test_the_margin_rule_takes_the_largest_exponent_that_passes_every_check_in_turn():
    """Hand-made NEES: at 100 particles 1.0 fails (12 > 10), 0.5 and 0.2 pass; at 1000 particles
    0.5 fails (9 > 7.81) and 0.2 passes, so 0.2 is chosen, 0.1 is never run at 1000, and a
    held-out row (not counted) that would fail 0.2 plays no part."""
    import pandas as pd

    from mazeslam.evaluation.consistency import choose_margin

    nees = {(100, 1.0): [12, 3], (100, 0.5): [9, 2], (100, 0.2): [5, 4], (100, 0.1): [2, 2]}
    nees |= {(1000, 0.5): [9, 1], (1000, 0.2): [7, 1]}
    calls = []

    def runs(exponents, particles):
        calls.append((exponents, particles))
        rows = [
            {"likelihood_exponent": e, "median_nees": value, "held_out": False}
            for e in exponents
            for value in nees[(particles, e)]
        ]
        return pd.DataFrame(
            rows + [{"likelihood_exponent": e, "median_nees": 99.0, "held_out": True} for e in exponents]
        )

    chosen, tables = choose_margin([1.0, 0.5, 0.2, 0.1], [(100, 10.0), (1000, 7.81)], runs, lambda t: ~t["held_out"])
    assert chosen == 0.2
    assert calls == [([1.0, 0.5, 0.2, 0.1], 100), ([0.5], 1000), ([0.2], 1000)]
    assert len(tables) == 3
    # counting the held-out rows too, nothing passes
    assert choose_margin([1.0, 0.5, 0.2, 0.1], [(100, 10.0), (1000, 7.81)], runs)[0] is None
