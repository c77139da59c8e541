"""The extended Kalman filter pieces FastSLAM is built of, as pure functions over batches.

Both of FastSLAM's Kalman steps use them: the landmark update (state: a landmark's position, d = 2)
and FastSLAM 2.0's pose proposal (state: the robot pose, d = 3). Shapes lead with a batch axis n
(particles, or particle-landmark pairs); observations are range and bearing ``z = (rho, phi)`` of a
point in the robot frame, with the measurement model ``h(x, m) = (|m - x|, atan2(m_y - y, m_x - x) - theta)``.
"""

from __future__ import annotations

import numpy as np

from mazeslam.geometry import wrap_angle


def range_bearing(poses: np.ndarray, landmarks: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Predicted observation of ``landmarks`` from ``poses`` and its Jacobians.

    Args:
        poses: (n, 3) x, y (m), theta (rad), world frame.
        landmarks: (n, 2) x, y (m), world frame.
    Returns:
        z_hat (n, 2): range (m) and bearing (rad, wrapped) of each landmark;
        h_landmark (n, 2, 2): d z_hat / d landmark;
        h_pose (n, 2, 3): d z_hat / d pose.
    """
    delta = landmarks - poses[:, :2]
    dx, dy = delta[:, 0], delta[:, 1]
    q = np.maximum(dx * dx + dy * dy, 1e-12)
    rho = np.sqrt(q)
    z_hat = np.column_stack([rho, wrap_angle(np.arctan2(dy, dx) - poses[:, 2])])
    h_landmark = np.stack([np.stack([dx / rho, dy / rho], -1), np.stack([-dy / q, dx / q], -1)], -2)
    minus_one = np.stack([np.zeros(len(poses)), -np.ones(len(poses))], -1)[..., None]
    h_pose = np.concatenate([-h_landmark, minus_one], -1)
    return z_hat, h_landmark, h_pose


def innovation(observed: np.ndarray, predicted: np.ndarray) -> np.ndarray:
    """Range-bearing innovation ``z - z_hat`` (..., 2), the bearing difference wrapped."""
    return np.stack([observed[..., 0] - predicted[..., 0], wrap_angle(observed[..., 1] - predicted[..., 1])], -1)


def update(
    mean: np.ndarray, covariance: np.ndarray, residual: np.ndarray, jacobian: np.ndarray, noise: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One EKF measurement update of a batch of Gaussians (filterpy's ``update(x, P, z, R, H)``).

    Args:
        mean: (n, d) state means.
        covariance: (n, d, d) state covariances.
        residual: (n, k) innovation ``z - h(mean)`` (angles already wrapped).
        jacobian: (n, k, d) H = dh/dstate at ``mean``.
        noise: (k, k) or (n, k, k) measurement noise R.
    Returns the updated means (n, d) and covariances (n, d, d) (Joseph form: symmetric and
    positive definite), and the innovation covariances S = H P H^T + R (n, k, k).
    """
    h_t = np.swapaxes(jacobian, -1, -2)
    s = jacobian @ covariance @ h_t + noise
    gain = covariance @ h_t @ np.linalg.inv(s)  # (n, d, k)
    new_mean = mean + np.einsum("nij,nj->ni", gain, residual)
    identity_minus = np.eye(mean.shape[1]) - gain @ jacobian
    new_covariance = identity_minus @ covariance @ np.swapaxes(identity_minus, -1, -2) + gain @ noise @ np.swapaxes(
        gain, -1, -2
    )
    return new_mean, new_covariance, s


def sample_gaussians(mean: np.ndarray, covariance: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """One draw from each Gaussian N(mean (n, d), covariance (n, d, d)): (n, d). Uses the
    eigendecomposition, so a covariance that is only positive semi-definite (a pose that has not
    moved) is fine."""
    values, vectors = np.linalg.eigh(covariance)
    draws = rng.standard_normal(mean.shape) * np.sqrt(np.clip(values, 0, None))
    return mean + np.einsum("nij,nj->ni", vectors, draws)
