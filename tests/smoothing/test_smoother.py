import numpy as np
import pytest

from mazeslam.core.geometry import advance_pose, relative, wrap_angle
from mazeslam.core.least_squares import relative_pose_residual
from mazeslam.core.motion import dead_reckoning
from mazeslam.data.loaded_run import load_run
from mazeslam.data.log import ODOMETRY, SCAN, CourseLog
from mazeslam.evaluation.metrics import absolute_trajectory_error
from mazeslam.fastslam.filter import FastSLAMParams
from mazeslam.features.corners import CornerExtractor
from mazeslam.pipeline.fastslam_run import truth_identities
from mazeslam.smoothing.smoother import (
    MOTION_FLOOR_VARIANCE,
    build_problem,
    compose_odometry,
    expand_to_records,
    range_bearing_residual,
    smooth_known_association,
    solve,
)

SIGMAS = {"sigma_x": 0.0027, "sigma_th": 0.017, "sigma_th_drive": 0.1}  # FastSLAMParams' defaults
INCREMENTS = np.array([[0.010, 0.02], [0.012, -0.05], [0.0, 0.3], [0.008, 0.1], [0.011, 0.0], [-0.005, 0.04]])


def course_log(kinds: str, increments) -> CourseLog:
    """A log in memory: ``kinds`` one letter a record ('o' odometry, 's' scan); the odometry
    records take ``increments`` (N, 2) in order. Scans hold no ranges (the tests name observations)."""
    flags = np.array([ODOMETRY if k == "o" else SCAN for k in kinds], dtype=np.int8)
    values = np.zeros((len(kinds), 2))
    values[flags == ODOMETRY] = increments
    return CourseLog(times=np.arange(len(kinds), dtype=float), flags=flags, values=values)


def central_difference(function, x: np.ndarray, step: float = 1e-6) -> np.ndarray:
    """d function / d x (n, k, d) by central differences, for a function of x (n, d) -> (n, k)."""
    columns = []
    for i in range(x.shape[1]):
        shift = np.zeros_like(x)
        shift[:, i] = step
        difference = function(x + shift) - function(x - shift)
        difference[:, -1] = wrap_angle(difference[:, -1])  # the last residual entry is an angle
        columns.append(difference / (2 * step))
    return np.stack(columns, -1)


def random_poses(rng, n: int) -> np.ndarray:
    return np.column_stack([rng.uniform(-1, 1, (n, 2)), rng.uniform(-np.pi, np.pi, n)])


def test_range_bearing_jacobians_match_central_differences():
    rng = np.random.default_rng(1)
    poses, landmarks = random_poses(rng, 20), rng.uniform(-1, 1, (20, 2))
    observations = np.column_stack([rng.uniform(0.1, 1, 20), rng.uniform(-np.pi, np.pi, 20)])
    _, j_pose, j_landmark = range_bearing_residual(poses, landmarks, observations)
    np.testing.assert_allclose(
        j_pose, central_difference(lambda p: range_bearing_residual(p, landmarks, observations)[0], poses), atol=1e-7
    )
    np.testing.assert_allclose(
        j_landmark,
        central_difference(lambda m: range_bearing_residual(poses, m, observations)[0], landmarks),
        atol=1e-7,
    )


def test_odometry_jacobians_match_central_differences():
    rng = np.random.default_rng(2)
    a, b, measured = random_poses(rng, 20), random_poses(rng, 20), random_poses(rng, 20)
    _, j_from, j_to = relative_pose_residual(a, b, measured)
    np.testing.assert_allclose(
        j_from, central_difference(lambda p: relative_pose_residual(p, b, measured)[0], a), atol=1e-7
    )
    np.testing.assert_allclose(
        j_to, central_difference(lambda p: relative_pose_residual(a, p, measured)[0], b), atol=1e-7
    )


def test_composed_odometry_is_the_path_and_its_covariance_the_record_by_record_recursion():
    composed, covariance = compose_odometry(INCREMENTS, **SIGMAS)
    pose, expected = np.zeros(3), np.zeros((3, 3))
    for distance, turn in INCREMENTS:  # Sigma <- F Sigma F^T + V Q V^T, as FastSLAM 2.0 carries it
        heading = pose[2] + 0.5 * turn
        f = np.array([[1, 0, -distance * np.sin(heading)], [0, 1, distance * np.cos(heading)], [0, 0, 1]])
        v = np.array(
            [
                [np.cos(heading), -0.5 * distance * np.sin(heading)],
                [np.sin(heading), 0.5 * distance * np.cos(heading)],
                [0, 1],
            ]
        )
        q = np.diag(
            [
                SIGMAS["sigma_x"] ** 2 * abs(distance),
                SIGMAS["sigma_th"] ** 2 * abs(turn) + SIGMAS["sigma_th_drive"] ** 2 * abs(distance),
            ]
        )
        expected = f @ expected @ f.T + v @ q @ v.T
        pose = advance_pose(pose, distance, turn)
    np.testing.assert_allclose(composed, pose, atol=1e-15)
    np.testing.assert_allclose(covariance, expected, atol=1e-18)
    empty, nothing = compose_odometry(np.empty((0, 2)), **SIGMAS)
    np.testing.assert_array_equal(empty, np.zeros(3))
    np.testing.assert_array_equal(nothing, np.zeros((3, 3)))


def test_composed_covariance_matches_monte_carlo():
    rng = np.random.default_rng(3)
    samples = 20000
    composed, covariance = compose_odometry(INCREMENTS, **SIGMAS)
    poses = np.zeros((samples, 3))
    for distance, turn in INCREMENTS:
        distance_std = SIGMAS["sigma_x"] * np.sqrt(abs(distance))
        turn_std = np.sqrt(SIGMAS["sigma_th"] ** 2 * abs(turn) + SIGMAS["sigma_th_drive"] ** 2 * abs(distance))
        poses = advance_pose(
            poses,
            distance + distance_std * rng.standard_normal(samples),
            turn + turn_std * rng.standard_normal(samples),
        )
    # Whitened by the predicted covariance, the draws have identity covariance and zero mean. With
    # 20000 draws the sampling error is sqrt(2/N) = 1 % on a variance, 0.7 % on a correlation, 0.7 %
    # of a std on the mean; the heading errors (~0.03 rad) bend the path by ~1e-3 relative, so the
    # first-order propagation is good to well under that. 5 % is over 5 sampling standard errors.
    errors = poses - composed
    errors[:, 2] = wrap_angle(errors[:, 2])
    whitened = errors @ np.linalg.inv(np.linalg.cholesky(covariance)).T
    np.testing.assert_allclose(np.cov(whitened.T), np.eye(3), atol=0.05)
    np.testing.assert_allclose(whitened.mean(axis=0), 0, atol=0.05)


def observe(poses: np.ndarray, landmarks: np.ndarray) -> np.ndarray:
    """Exact range and bearing (n, 2) of landmarks (n, 2) from poses (n, 3)."""
    residual, _, _ = range_bearing_residual(poses, landmarks, np.zeros((len(poses), 2)))
    return residual


def test_noise_free_problem_is_recovered_from_a_perturbed_start():
    start = np.array([0.2, -0.1, 0.4])
    log = course_log("soosos", [[0.3, 0.2], [0.2, 0.1], [0.4, -0.3]])
    truth = dead_reckoning(log, start)[log.is_scan]  # (3, 3) the scan poses
    landmarks = np.array([[1.0, 0.8], [0.6, -0.5]])
    observations = [observe(np.repeat(pose[None], 2, 0), landmarks) for pose in truth]
    params = FastSLAMParams(sigmaR=0.01, sigmaB=0.01, observation_scale=0.0)
    problem = build_problem(log, observations, [np.zeros((2, 2, 2))] * 3, [np.array([5, 9])] * 3, params, start)
    rng = np.random.default_rng(4)
    problem.initial_poses = truth + rng.normal(0, [0.05, 0.05, 0.1], (3, 3))
    problem.initial_landmarks = landmarks + rng.normal(0, 0.05, (2, 2))
    result = solve(problem)
    assert result.converged and result.iterations <= 10
    np.testing.assert_allclose(result.poses, truth, atol=1e-9)
    np.testing.assert_allclose(result.landmarks, landmarks, atol=1e-9)
    np.testing.assert_array_equal(result.landmark_ids, [5, 9])
    assert result.chi2 < 1e-12
    assert result.dof == 3 * 3 + 3 * 2 * 2 - (3 * 3 + 2 * 2)


def test_conflicting_ranges_are_reconciled_by_their_variances():
    # Start at the origin facing +x, scan, drive d = 1 m, scan; one landmark straight ahead seen at
    # rho1 from the start and rho2 after the drive. The loop misses by c = rho1 - d - rho2; least
    # squares moves each measurement against c in proportion to its variance:
    # m = rho1 - v1 c / V, x1 = d + q c / V with V = v1 + q + v2.
    log = course_log("sos", [[1.0, 0.0]])
    rho1, rho2, v1, v2 = 2.0, 0.98, 4e-4, 1e-4
    params = FastSLAMParams(sigmaX=0.01, sigmaR=0.0, sigmaB=0.0)
    q = params.sigmaX**2 * 1.0
    covariances = [np.diag([v, 1e-4])[None] for v in (v1, v2)]
    result = solve(
        build_problem(
            log, [np.array([[rho1, 0.0]]), np.array([[rho2, 0.0]])], covariances, [np.array([7]), np.array([7])], params
        )
    )
    c, total = rho1 - 1.0 - rho2, v1 + q + v2
    np.testing.assert_allclose(result.landmarks, [[rho1 - v1 * c / total, 0.0]], atol=1e-9)
    np.testing.assert_allclose(result.poses, [[0, 0, 0], [1.0 + q * c / total, 0, 0]], atol=1e-9)
    assert result.chi2 == pytest.approx(c**2 / total, rel=1e-6)
    assert result.dof == 2 * 3 + 2 * 2 - (2 * 3 + 2)
    # Covariance of (x1, m): with x0 fixed the inverse of the information [[1/q + 1/v2, -1/v2],
    # [-1/v2, 1/v1 + 1/v2]]; x0 is tied to the start by a factor of the floor's variance, which adds to both.
    information = np.array([[1 / q + 1 / v2, -1 / v2], [-1 / v2, 1 / v1 + 1 / v2]])
    expected = np.linalg.inv(information) + MOTION_FLOOR_VARIANCE
    assert result.pose_covariances[1, 0, 0] == pytest.approx(expected[0, 0], rel=1e-6)
    assert result.landmark_covariances[0, 0, 0] == pytest.approx(expected[1, 1], rel=1e-6)


def test_poses_at_every_record_follow_the_odometry_from_the_last_scan():
    start = np.array([0.1, 0.2, 0.3])
    log = course_log("oosoos", INCREMENTS[:4])
    scans = np.flatnonzero(log.is_scan)
    reckoned = dead_reckoning(log, start)
    no_observations = [np.empty((0, 2))] * 2
    problem = build_problem(
        log, no_observations, [np.empty((0, 2, 2))] * 2, [np.empty(0, int)] * 2, FastSLAMParams(), start
    )
    result = solve(problem)
    np.testing.assert_allclose(expand_to_records(log, result, start), reckoned, atol=1e-12)  # nothing to correct
    result.poses = result.poses + [0.01, -0.02, 0.1]  # move the scan poses: the records after them follow
    expanded = expand_to_records(log, result, start)
    np.testing.assert_allclose(expanded[:2], reckoned[:2], atol=1e-12)  # before the first scan
    np.testing.assert_allclose(expanded[scans], result.poses, atol=1e-12)
    np.testing.assert_allclose(relative(expanded[2], expanded[3:5]), relative(reckoned[2], reckoned[3:5]), atol=1e-12)


def test_smoother_beats_dead_reckoning_on_a_simulated_run(default_run):
    run = load_run(default_run.log_path)
    extractor = CornerExtractor(run.geometry, run.log.width)
    result = smooth_known_association(run.log, extractor, truth_identities(run, 0.05), FastSLAMParams(), run.start_pose)
    truth = run.truth[result.scan_records]
    reckoned = dead_reckoning(run.log, run.start_pose)[result.scan_records]
    # Seeds 0, 404, 505, 606, 707, 808 measured 1.7-11 mm (0.59-0.91 mm aligned) against dead
    # reckoning's 15-53 mm (10-26 mm), converging in 8 iterations with chi2/dof 0.38-0.51.
    assert result.converged and result.iterations <= 15
    for align, factor in ((False, 0.5), (True, 0.1)):
        error = absolute_trajectory_error(result.poses, truth, align=align)["rmse"]
        assert error < factor * absolute_trajectory_error(reckoned, truth, align=align)["rmse"]
    assert 0.2 < result.chi2_per_dof < 1.0
    assert len(expand_to_records(run.log, result, run.start_pose)) == len(run.log)
