"""Where FastSLAM draws each particle's pose from: its two proposal distributions.

``MotionProposal`` (FastSLAM 1.0, the exercise's): the pose is drawn from the motion model when the
robot moves; the scan only weighs it. ``ObservationProposal`` (FastSLAM 2.0, Montemerlo et al.
2003): the motion's mean and covariance are carried until the next scan, corrected there by the
scan's associated observations, and the pose is drawn from that Gaussian; this keeps particles alive
when the sensor is much more precise than the odometry.

Both work on the particle arrays they are given and return new ones:
    poses             (P, 3)     x, y (m), theta (rad), world frame
    pose_covariances  (P, 3, 3)  the motion's covariance not yet drawn (zeros for FastSLAM 1.0)
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from mazeslam.core.geometry import advance_pose, compose, wrap_angle
from mazeslam.core.motion import OdometryNoise, predict_odometry, predict_relative
from mazeslam.fastslam import ekf


class Proposal(Protocol):
    """What ``FastSLAM`` asks of a proposal: ``MotionProposal`` or ``ObservationProposal``."""

    carries_pose_uncertainty: bool

    def predict(
        self,
        poses: np.ndarray,
        pose_covariances: np.ndarray,
        distance: float,
        turn: float,
        noise: OdometryNoise,
        rng: np.random.Generator,
    ) -> tuple[np.ndarray, np.ndarray]: ...

    def predict_relative(
        self,
        poses: np.ndarray,
        pose_covariances: np.ndarray,
        increment: np.ndarray,
        covariance: np.ndarray,
        rng: np.random.Generator,
    ) -> tuple[np.ndarray, np.ndarray]: ...

    def draw(
        self,
        poses: np.ndarray,
        pose_covariances: np.ndarray,
        assigned: np.ndarray,
        observations: np.ndarray,
        means: np.ndarray,
        covariances: np.ndarray,
        noise: np.ndarray,
        rng: np.random.Generator,
    ) -> tuple[np.ndarray, np.ndarray, tuple[np.ndarray, np.ndarray] | None]: ...


class MotionProposal:
    """FastSLAM 1.0: draw the motion noise as the robot moves; observations only weigh."""

    #: The weights' predictive covariance holds no pose uncertainty: the pose is already drawn.
    carries_pose_uncertainty = False

    def predict(
        self, poses, pose_covariances, distance: float, turn: float, noise: OdometryNoise, rng: np.random.Generator
    ):
        """Move by an odometry increment (m, rad), drawing each particle's noise now."""
        return predict_odometry(poses, distance, turn, noise, rng), pose_covariances

    def predict_relative(
        self, poses, pose_covariances, increment: np.ndarray, covariance: np.ndarray, rng: np.random.Generator
    ):
        """Move by a robot-frame motion (dx, dy, dth) with covariance (3, 3), drawing the noise now."""
        return predict_relative(poses, increment, covariance, rng), pose_covariances

    def draw(self, poses, pose_covariances, assigned, observations, means, covariances, noise, rng):
        """Nothing left to draw: the poses already hold their motion noise, and each observation's
        likelihood is its own (None: the weights use the association's model)."""
        return poses, pose_covariances, None


class ObservationProposal:
    """FastSLAM 2.0: carry the motion's Gaussian to the scan, correct it by the observations, draw."""

    #: The weights' predictive covariance includes the pose's (motion) uncertainty.
    carries_pose_uncertainty = True

    def predict(
        self, poses, pose_covariances, distance: float, turn: float, noise: OdometryNoise, rng: np.random.Generator
    ):
        """Move the means by an odometry increment (m, rad) and propagate the covariance,
        F Sigma F^T + V Q V^T with the Jacobians of ``advance_pose`` w.r.t. the pose (F) and to
        (distance, turn) (V)."""
        if distance == 0.0 and turn == 0.0:
            return poses, pose_covariances
        heading = poses[:, 2] + 0.5 * turn
        cos_h, sin_h = np.cos(heading), np.sin(heading)
        carried = _through_heading(pose_covariances, -distance * sin_h, distance * cos_h)
        # V Q V^T, V = [[cos_h, -d/2 sin_h], [sin_h, d/2 cos_h], [0, 1]], entry by entry (P,).
        q = noise.increment_covariance(distance, turn)
        v = ((cos_h, -0.5 * distance * sin_h), (sin_h, 0.5 * distance * cos_h))
        vq = [[row[0] * q[0, j] + row[1] * q[1, j] for j in range(2)] for row in v] + [[q[1, 0], q[1, 1]]]
        for i in range(3):
            for j in range(2):
                carried[:, i, j] += vq[i][0] * v[j][0] + vq[i][1] * v[j][1]
            carried[:, i, 2] += vq[i][1]
        return advance_pose(poses, distance, turn), carried

    def predict_relative(
        self, poses, pose_covariances, increment: np.ndarray, covariance: np.ndarray, rng: np.random.Generator
    ):
        """Move the means by a robot-frame motion (dx, dy, dth) and propagate the covariance through
        the Jacobians of ``compose(pose, increment)`` w.r.t. the pose (F) and the increment (V)."""
        cos_t, sin_t = np.cos(poses[:, 2]), np.sin(poses[:, 2])
        f02 = -sin_t * increment[0] - cos_t * increment[1]
        f12 = cos_t * increment[0] - sin_t * increment[1]
        v = np.tile(np.eye(3), (len(poses), 1, 1))
        v[:, 0, 0], v[:, 0, 1], v[:, 1, 0], v[:, 1, 1] = cos_t, -sin_t, sin_t, cos_t
        return compose(poses, increment), _through_heading(pose_covariances, f02, f12) + ekf.congruence(covariance, v)

    def draw(self, poses, pose_covariances, assigned, observations, means, covariances, noise, rng):
        """Correct each particle's motion Gaussian by its associated observations (one EKF step
        each, in turn) and draw the pose from the result.

        Args:
            assigned: (P, K) the landmark slot each observation is associated with (-1: none).
            observations: (K, 2) range (m) and bearing (rad) in the robot frame.
            means, covariances: (P, M, 2) and (P, M, 2, 2) every particle's landmarks.
            noise: (K, 2, 2) the observations' noise R.
        Returns the drawn poses (P, 3), zeroed pose covariances, and for the weights the squared
        Mahalanobis distance and determinant (P, K) of each associated observation's innovation
        under its predictive covariance given the scan's observations before it (NaN where not
        associated). Their product over the scan is the joint likelihood of the scan; each
        observation's marginal alone would count the motion's uncertainty, which all of them
        share, once per observation.
        """
        mean, covariance = poses.copy(), pose_covariances.copy()
        distance2 = np.full(assigned.shape, np.nan)
        determinant = np.full(assigned.shape, np.nan)
        for k, observation in enumerate(observations):
            rows = np.flatnonzero(assigned[:, k] >= 0)
            if not len(rows):
                continue
            slots = assigned[rows, k]
            at = slice(None) if len(rows) == len(assigned) else rows  # every particle: no copies in and out
            z_hat, h_landmark, h_pose = ekf.range_bearing(mean[at], means[rows, slots])
            landmark_noise = ekf.congruence(covariances[rows, slots], h_landmark) + noise[k]
            residual = ekf.innovation(observation, z_hat)
            mean[at], covariance[at], s = ekf.update(mean[at], covariance[at], residual, h_pose, landmark_noise)
            s00, s01, s11 = s[:, 0, 0], s[:, 0, 1], s[:, 1, 1]
            det = s00 * s11 - s01 * s01
            if not det.min() > 0:  # ekf.update checked S, but rounding may still differ: checked before dividing
                raise ekf.NotPositiveDefinite("an innovation covariance (H P H^T + R) is not positive definite")
            determinant[rows, k] = det
            nu0, nu1 = residual[:, 0], residual[:, 1]
            distance2[rows, k] = (s11 * nu0 * nu0 - 2 * s01 * nu0 * nu1 + s00 * nu1 * nu1) / det
        drawn = ekf.sample_gaussians(mean, covariance, rng)
        drawn[:, 2] = wrap_angle(drawn[:, 2])
        return drawn, np.zeros_like(covariance), (distance2, determinant)


def _through_heading(covariance: np.ndarray, f02: np.ndarray, f12: np.ndarray) -> np.ndarray:
    """F Sigma F^T (P, 3, 3) of pose covariances Sigma (P, 3, 3) through a motion's Jacobian w.r.t.
    the pose, F = identity but for its last column (f02, f12, 1) (each (P,): how x and y move with
    the heading). Entry by entry, the terms of F's zeros and ones left out: the same sums as the
    full product (``ekf.congruence``) but a third of the work."""
    f = (f02, f12)
    rows = [covariance[:, i] + f[i][:, None] * covariance[:, 2] for i in range(2)] + [covariance[:, 2]]  # F Sigma
    out = np.empty_like(covariance)
    for i, row in enumerate(rows):
        out[:, i, 0] = row[:, 0] + f02 * row[:, 2]
        out[:, i, 1] = row[:, 1] + f12 * row[:, 2]
        out[:, i, 2] = row[:, 2]
    return out


PROPOSALS: dict[int, type[Proposal]] = {1: MotionProposal, 2: ObservationProposal}
