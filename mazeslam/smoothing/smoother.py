"""Batch maximum-a-posteriori SLAM (least squares over the whole log): the reference beside FastSLAM.

The unknowns are the robot poses at the scan records and the landmark positions; the start pose is
known and fixed (eliminated: it is a constant, not an unknown). Two kinds of factors tie them:

* odometry: the odometry records between two scans composed into one relative pose
  (dx, dy, dth) in the frame of the first, with its covariance carried through the motion
  Jacobians (``compose_odometry``); the first scan's factor starts at the fixed start pose;
* observation: a corner's range and bearing ``z = (rho, phi)`` seen from a scan pose, with the
  measurement model ``h(x, m) = (|m - x|, atan2(m_y - y, m_x - x) - theta)`` and noise as in
  FastSLAM: the observation's own covariance plus ``diag(sigmaR^2, sigmaB^2)``.

``solve`` minimises the sum of squared whitened residuals by Levenberg-Marquardt on a sparse
Jacobian (``scipy.sparse``), starting from dead reckoning, and reads each pose's and landmark's
covariance off the information matrix at the optimum (Gauss-Newton's Laplace approximation).

Frames and units: world frame x, y in metres, headings in radians wrapped to (-pi, pi]; a relative
pose is given in the frame of the pose it starts from; observations are in the robot frame.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
import scipy.sparse
import scipy.sparse.linalg

from mazeslam.core.geometry import (
    polar_to_cartesian,
    transform_points,
    wrap_angle,
)
from mazeslam.core.least_squares import block_entries, relative_pose_residual
from mazeslam.core.motion import carried_to_records, dead_reckoning
from mazeslam.data.log import CourseLog
from mazeslam.fastslam import ekf
from mazeslam.fastslam.filter import FastSLAMParams
from mazeslam.features.corners import CornerExtractor

#: Variance (m^2 and rad^2) added to the diagonal of every odometry factor's covariance. The
#: composed covariance is singular where the robot did not move between two scans (zero), turned
#: on the spot (no position variance: it grows with the distance only) or moved by a single record
#: (its lateral offset is tied to its turn). The floor, 10 um and 10 urad, is far below what a
#: corner measures (mm) and keeps the normal equations well conditioned: on simulated logs 1e-12
#: gave the same estimates but needed 8 iterations instead of 6 to 7.
MOTION_FLOOR_VARIANCE = 1e-10


# -- factors: residuals and their analytic Jacobians ----------------------------------------------


def compose_odometry(
    increments: np.ndarray, sigma_x: float, sigma_th: float, sigma_th_drive: float
) -> tuple[np.ndarray, np.ndarray]:
    """The relative pose of a run of odometry records and its first-order covariance.

    Record k moves the pose by ``advance_pose(pose, d_k, t_k)`` (a midpoint arc) with independent
    noise of variance ``sigma_x^2 |d_k|`` on the distance and ``sigma_th^2 |t_k| +
    sigma_th_drive^2 |d_k|`` on the turn (``mazeslam.core.motion``). The end pose's covariance is
    ``sum_k G_k Q_k G_k^T`` with ``G_k = F_k V_k``: V_k (3, 2) the Jacobian of record k's step with
    respect to its (d, t), and F_k (3, 3) that of the end pose with respect to the pose after record
    k (a heading error there swings the rest of the path about it). This is the recursion
    ``Sigma <- F Sigma F^T + V Q V^T`` record by record, in closed form.

    Args:
        increments: (N, 2) distance (m) and turn (rad) of each record, in order; N may be 0.
        sigma_x: distance noise, m per sqrt(m) travelled.
        sigma_th: heading noise from turning, rad per sqrt(rad) turned.
        sigma_th_drive: heading noise from driving, rad per sqrt(m) travelled.
    Returns:
        relative (3,): dx, dy (m), dth (rad, wrapped), in the frame of the pose before the records.
        covariance (3, 3): its covariance (m^2, m rad, rad^2).
    """
    increments = np.asarray(increments, dtype=float).reshape(-1, 2)
    distance, turn = increments[:, 0], increments[:, 1]
    # 1. The path: heading halfway through each record, position after each record.
    midway = np.cumsum(turn) - 0.5 * turn
    heading = np.column_stack([np.cos(midway), np.sin(midway)])  # (N, 2) unit vectors
    step = distance[:, None] * heading
    after = np.cumsum(step, axis=0)
    end = after[-1] if len(after) else np.zeros(2)
    # 2. G_k = F_k V_k: d(end pose)/d(d_k, t_k).
    lever = end - after  # (N, 2) from the pose after record k to the end
    g = np.zeros((len(distance), 3, 2))
    g[:, :2, 0] = heading
    g[:, 0, 1] = -0.5 * step[:, 1] - lever[:, 1]
    g[:, 1, 1] = 0.5 * step[:, 0] + lever[:, 0]
    g[:, 2, 1] = 1.0
    # 3. Sum of G_k Q_k G_k^T, Q_k diagonal.
    q = np.column_stack(
        [sigma_x**2 * np.abs(distance), sigma_th**2 * np.abs(turn) + sigma_th_drive**2 * np.abs(distance)]
    )
    covariance = np.einsum("kia,ka,kja->ij", g, q, g)
    return np.array([end[0], end[1], wrap_angle(turn.sum())]), covariance


def range_bearing_residual(
    poses: np.ndarray, landmarks: np.ndarray, observations: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Residual ``h(pose, landmark) - z`` of range-bearing observations, and its Jacobians
    (``ekf.range_bearing``'s).

    Args:
        poses: (n, 3) x, y (m), theta (rad), world frame.
        landmarks: (n, 2) x, y (m), world frame.
        observations: (n, 2) observed range (m) and bearing (rad), robot frame.
    Returns:
        residual (n, 2): range (m) and bearing (rad, wrapped) differences;
        j_pose (n, 2, 3): d residual / d pose;
        j_landmark (n, 2, 2): d residual / d landmark.
    """
    predicted, j_landmark, j_pose = ekf.range_bearing(poses, landmarks)
    return -ekf.innovation(observations, predicted), j_pose, j_landmark


# -- the problem ----------------------------------------------------------------------------------


@dataclass
class SmoothingProblem:
    """A batch SLAM problem: S scan poses, L landmarks, K observations.

    Attributes:
        start_pose: (3,) the fixed pose before the first record, world frame.
        scan_records: (S,) the log's record index of each scan pose.
        odometry: (S, 3) relative pose from the previous scan pose (the start pose for the first)
            to each scan pose, in the frame of the former; odometry_covariances (S, 3, 3) its
            covariance.
        observations: (K, 2) range (m), bearing (rad); observation_covariances (K, 2, 2) their noise.
        observation_poses: (K,) which scan pose (0..S-1) saw each observation.
        observation_landmarks: (K,) which landmark (0..L-1) each observation is.
        landmark_ids: (L,) the identity of each landmark.
        initial_poses: (S, 3) and initial_landmarks (L, 2): where the solver starts.
    """

    start_pose: np.ndarray
    scan_records: np.ndarray
    odometry: np.ndarray
    odometry_covariances: np.ndarray
    observations: np.ndarray
    observation_covariances: np.ndarray
    observation_poses: np.ndarray
    observation_landmarks: np.ndarray
    landmark_ids: np.ndarray
    initial_poses: np.ndarray
    initial_landmarks: np.ndarray


@dataclass
class SmoothingResult:
    """The MAP estimate of a ``SmoothingProblem``.

    Attributes:
        scan_records: (S,) record index of each pose.
        poses: (S, 3) and pose_covariances (S, 3, 3): world frame, m and rad.
        landmark_ids: (L,) and landmarks (L, 2), landmark_covariances (L, 2, 2): world frame, m.
        iterations: linear solves the optimiser made.
        chi2: sum of squared whitened residuals at the optimum; dof: residual dimensions minus
            unknowns (chi2 / dof near 1: the noise models fit the residuals).
        converged: the last step moved no unknown by more than the tolerance.
    """

    scan_records: np.ndarray
    poses: np.ndarray
    pose_covariances: np.ndarray
    landmark_ids: np.ndarray
    landmarks: np.ndarray
    landmark_covariances: np.ndarray
    iterations: int
    chi2: float
    dof: int
    converged: bool

    @property
    def chi2_per_dof(self) -> float:
        return self.chi2 / self.dof if self.dof > 0 else float("nan")


def build_problem(
    course_log: CourseLog,
    observations: list[np.ndarray],
    covariances: list[np.ndarray],
    ids: list[np.ndarray],
    params: FastSLAMParams,
    start_pose=(0.0, 0.0, 0.0),
) -> SmoothingProblem:
    """A ``SmoothingProblem`` from a log and its scans' associated observations.

    Args:
        course_log: the log; its odometry records give the odometry factors, its scan records the poses.
        observations: per scan record in order, (K_s, 2) range (m) and bearing (rad), robot frame.
        covariances: per scan record, (K_s, 2, 2) their covariances (the corner extractor's).
        ids: per scan record, (K_s,) the landmark identity of each observation; -1: left out.
        params: the noise terms sigmaX, sigmaTH, sigmaTH_drive, sigmaR, sigmaB and
            observation_scale as measured (``FastSLAMParams.observation_noise``: without the filter's inflation).
        start_pose: (3,) the fixed start pose, world frame.
    The solver starts from dead reckoning, and each landmark where its first observation puts it.
    """
    start_pose = np.asarray(start_pose, dtype=float)
    scan_records = np.flatnonzero(course_log.is_scan)
    if not len(scan_records):
        raise ValueError(f"{course_log.source}: the log has no scan records, so no poses to estimate")
    if not len(observations) == len(covariances) == len(ids) == len(scan_records):
        raise ValueError(
            f"need observations, covariances and ids for each of the {len(scan_records)} scans, "
            f"got {len(observations)}, {len(covariances)} and {len(ids)}"
        )
    # 1. Odometry factors: the records since the previous scan (or the start), composed.
    increments = course_log.increments
    bounds = np.concatenate([[0], scan_records + 1])
    composed = [
        compose_odometry(increments[a:b], params.sigmaX, params.sigmaTH, params.sigmaTH_drive)
        for a, b in itertools.pairwise(bounds)
    ]
    odometry = np.array([z for z, _ in composed]).reshape(-1, 3)
    odometry_covariances = np.array([c for _, c in composed]).reshape(-1, 3, 3) + MOTION_FLOOR_VARIANCE * np.eye(3)
    # 2. Observation factors: the named observations, with FastSLAM's noise.
    used = [np.asarray(i) >= 0 for i in ids]
    z = np.concatenate([np.asarray(o, dtype=float).reshape(-1, 2)[u] for o, u in zip(observations, used)])
    noise = np.concatenate([np.asarray(c, dtype=float).reshape(-1, 2, 2)[u] for c, u in zip(covariances, used)])
    noise = params.observation_noise(noise, len(noise))
    seen_from = np.concatenate([np.full(u.sum(), s) for s, u in enumerate(used)]).astype(int)
    named = np.concatenate([np.asarray(i)[u] for i, u in zip(ids, used)]).astype(int)
    landmark_ids, which = np.unique(named, return_inverse=True)
    # 3. Initial guesses: dead reckoning, and each landmark's first observation from there.
    poses = dead_reckoning(course_log, start_pose)[scan_records]
    first = np.unique(which, return_index=True)[1]
    landmarks = np.array([transform_points(poses[seen_from[k]], polar_to_cartesian(*z[k])) for k in first])
    return SmoothingProblem(
        start_pose,
        scan_records,
        odometry,
        odometry_covariances,
        z,
        noise,
        seen_from,
        which,
        landmark_ids,
        poses,
        landmarks.reshape(-1, 2),
    )


# -- the solver -----------------------------------------------------------------------------------


def solve(problem: SmoothingProblem, max_iterations: int = 50, step_tolerance: float = 1e-7) -> SmoothingResult:
    """The MAP estimate of ``problem`` by Levenberg-Marquardt with a sparse Jacobian.

    Each iteration solves ``(J^T J + lambda diag(J^T J)) delta = -J^T r`` for the whitened residual
    r and Jacobian J (``scipy.sparse.linalg.spsolve``) and keeps the step if it lowers chi2
    (lambda / 10) or retries with lambda x 10. It stops once a step would move no unknown by more
    than ``step_tolerance`` (m or rad): there chi2 changes only in its last digits, so such a step
    is kept only if it does not raise chi2.

    Covariances: the diagonal blocks of ``(J^T J)^-1`` at the optimum (``marginal_covariances``).
    """
    pose_count, landmark_count = len(problem.initial_poses), len(problem.initial_landmarks)
    odometry_whitener = _whitener(problem.odometry_covariances)
    observation_whitener = _whitener(problem.observation_covariances)

    def linearise(poses, landmarks):
        r, j = _whitened_system(problem, poses, landmarks, odometry_whitener, observation_whitener)
        return r, j, float(r @ r)

    poses, landmarks = problem.initial_poses.copy(), problem.initial_landmarks.copy()
    r, j, chi2 = linearise(poses, landmarks)
    damping, iterations, converged = 1e-6, 0, False
    while iterations < max_iterations and not converged:
        # 1. Damped normal equations.
        information, gradient = (j.T @ j).tocsc(), j.T @ r
        damped = information + damping * scipy.sparse.diags_array(information.diagonal())
        step = scipy.sparse.linalg.spsolve(damped, -gradient)
        iterations += 1
        # 2. Try the step: keep it if chi2 falls.
        new_poses, new_landmarks = _moved(poses, landmarks, step)
        new_r, new_j, new_chi2 = linearise(new_poses, new_landmarks)
        converged = np.abs(step).max(initial=0.0) <= step_tolerance
        if new_chi2 <= chi2:
            poses, landmarks, r, j, chi2 = new_poses, new_landmarks, new_r, new_j, new_chi2
            damping = max(damping / 10, 1e-12)
        elif not converged:
            damping *= 10
    # 3. Covariances from the information matrix at the optimum.
    pose_covariances, landmark_covariances = marginal_covariances(j.T @ j, ((pose_count, 3), (landmark_count, 2)))
    degrees_of_freedom = len(r) - (3 * pose_count + 2 * landmark_count)
    return SmoothingResult(
        problem.scan_records,
        poses,
        pose_covariances,
        problem.landmark_ids,
        landmarks,
        landmark_covariances,
        iterations,
        chi2,
        degrees_of_freedom,
        bool(converged),
    )


def marginal_covariances(information: scipy.sparse.sparray, sizes: tuple[tuple[int, int], ...]) -> list[np.ndarray]:
    """Diagonal blocks of the inverse of an information matrix (n, n): the covariances of groups of
    consecutive unknowns, given as ``(count, size)`` pairs in order (count unknowns of size entries
    each), one array (count, size, size) per group.

    Inverts the matrix densely: O(n^2) memory and O(n^3) work, fine for a few thousand unknowns
    (a log of ~150 scans and ~25 landmarks has ~500: milliseconds), not for tens of thousands.
    """
    covariance = np.linalg.inv(information.toarray())
    blocks, offset = [], 0
    for count, size in sizes:
        end = offset + count * size
        part = covariance[offset:end, offset:end].reshape(count, size, count, size)
        blocks.append(part[np.arange(count), :, np.arange(count), :])
        offset += count * size
    return blocks


def _whitener(covariances: np.ndarray) -> np.ndarray:
    """W (n, k, k) with W^T W = C^-1 for covariances C (n, k, k): the inverse Cholesky factor."""
    return np.linalg.inv(np.linalg.cholesky(covariances))


def _whitened_system(
    problem: SmoothingProblem,
    poses: np.ndarray,
    landmarks: np.ndarray,
    odometry_whitener: np.ndarray,
    observation_whitener: np.ndarray,
):
    """The whitened residual (M,) and sparse Jacobian (M, 3S + 2L) at ``poses`` (S, 3), ``landmarks``
    (L, 2). Rows: 3 per odometry factor, then 2 per observation. Columns: the poses, then the landmarks."""
    s = len(poses)
    # 1. Odometry factors: previous pose (the fixed start pose for the first) to each pose.
    previous = np.vstack([problem.start_pose, poses[:-1]])
    r_odo, j_from, j_to = relative_pose_residual(previous, poses, problem.odometry)
    # 2. Observation factors.
    k = problem.observation_poses
    r_obs, j_pose, j_landmark = range_bearing_residual(
        poses[k], landmarks[problem.observation_landmarks], problem.observations
    )
    # 3. Whiten and place the blocks.
    w_odo, w_obs = odometry_whitener, observation_whitener
    blocks = [
        (w_odo @ j_to, 3 * np.arange(s), 3 * np.arange(s)),
        ((w_odo @ j_from)[1:], 3 * np.arange(1, s), 3 * np.arange(s - 1)),
        (w_obs @ j_pose, 3 * s + 2 * np.arange(len(k)), 3 * k),
        (w_obs @ j_landmark, 3 * s + 2 * np.arange(len(k)), 3 * s + 2 * problem.observation_landmarks),
    ]
    rows, columns, values = zip(*(block_entries(*block) for block in blocks))
    shape = (3 * s + 2 * len(k), 3 * s + 2 * len(landmarks))
    entries = (np.concatenate(values), (np.concatenate(rows), np.concatenate(columns)))
    jacobian = scipy.sparse.csr_array(entries, shape)
    residual = np.concatenate(
        [np.einsum("nij,nj->ni", w_odo, r_odo).ravel(), np.einsum("nij,nj->ni", w_obs, r_obs).ravel()]
    )
    return residual, jacobian


def _moved(poses: np.ndarray, landmarks: np.ndarray, step: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Poses (S, 3) and landmarks (L, 2) moved by a step (3S + 2L,), headings wrapped."""
    s = len(poses)
    new_poses = poses + step[: 3 * s].reshape(-1, 3)
    new_poses[:, 2] = wrap_angle(new_poses[:, 2])
    return new_poses, landmarks + step[3 * s :].reshape(-1, 2)


# -- whole logs -----------------------------------------------------------------------------------


def expand_to_records(course_log: CourseLog, result: SmoothingResult, start_pose=(0.0, 0.0, 0.0)) -> np.ndarray:
    """Poses (R, 3) at every record of ``course_log``, like FastSLAM's: each record's pose is the
    last scan pose at or before it (the start pose before the first scan) moved by the odometry
    since then (``carried_to_records``). World frame."""
    start = np.asarray(start_pose, dtype=float)
    reckoned = dead_reckoning(course_log, start)
    return carried_to_records(result.scan_records, result.poses, result.pose_covariances, reckoned, start)[0]


def smooth_known_association(
    course_log: CourseLog, extractor: CornerExtractor, identify, params: FastSLAMParams, start_pose=(0.0, 0.0, 0.0)
) -> SmoothingResult:
    """The MAP estimate of a scan log with known association.

    Extracts the corners of every scan with ``extractor``, names them with
    ``identify(record_index, observations (K, 2)) -> ids (K,)`` (as ``mazeslam.fastslam.identities.truth_identities``
    returns; -1: left out), and solves.
    """
    observations, covariances, ids = [], [], []
    for record in np.flatnonzero(course_log.is_scan):
        features = extractor.extract(course_log.values[record])
        observations.append(features.observation_array())
        covariances.append(features.observation_covariances())
        ids.append(identify(int(record), observations[-1]))
    return solve(build_problem(course_log, observations, covariances, ids, params, start_pose))
