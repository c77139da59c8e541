"""The extended Kalman filter pieces FastSLAM is built of, as pure functions over batches.

Both of FastSLAM's Kalman steps use them: the landmark update (state: a landmark's position, d = 2)
and FastSLAM 2.0's pose proposal (state: the robot pose, d = 3). Shapes lead with a batch axis n
(particles, or particle-landmark pairs); observations are range and bearing ``z = (rho, phi)`` of a
point in the robot frame, with the measurement model ``h(x, m) = (|m - x|, atan2(m_y - y, m_x - x) - theta)``.
"""

from __future__ import annotations

import numpy as np

TWO_PI = 2.0 * np.pi
#: Batches at least this large are computed entry by entry (a few passes over memory); smaller ones
#: with numpy's batched ``matmul`` (a few calls: few particles cost little more than the calls).
ENTRYWISE_FROM = 64


def wrap(angle: np.ndarray) -> np.ndarray:
    """Angles (rad, any shape and size) wrapped to [-pi, pi]: a rounding, a multiply and a subtract,
    several times cheaper than ``geometry.wrap_angle``'s modulo (which also returns floats for
    scalars and keeps -pi out); for the filter's innovations and predicted bearings."""
    return angle - TWO_PI * np.round(angle / TWO_PI)


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
    z_hat = np.column_stack([rho, wrap(np.arctan2(dy, dx) - poses[:, 2])])
    h_landmark = np.stack([np.stack([dx / rho, dy / rho], -1), np.stack([-dy / q, dx / q], -1)], -2)
    minus_one = np.stack([np.zeros(len(poses)), -np.ones(len(poses))], -1)[..., None]
    h_pose = np.concatenate([-h_landmark, minus_one], -1)
    return z_hat, h_landmark, h_pose


def innovation(observed: np.ndarray, predicted: np.ndarray) -> np.ndarray:
    """Range-bearing innovation ``z - z_hat`` (..., 2), the bearing difference wrapped."""
    return np.stack([observed[..., 0] - predicted[..., 0], wrap(observed[..., 1] - predicted[..., 1])], -1)


def update(
    mean: np.ndarray, covariance: np.ndarray, residual: np.ndarray, jacobian: np.ndarray, noise: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One EKF measurement update of a batch of Gaussians (filterpy's ``update(x, P, z, R, H)``).

    Args:
        mean: (n, d) state means.
        covariance: (n, d, d) state covariances.
        residual: (n, k) innovation ``z - h(mean)`` (angles already wrapped), k = 1 or 2.
        jacobian: (n, k, d) H = dh/dstate at ``mean``.
        noise: (k, k) or (n, k, k) measurement noise R.
    Returns the updated means (n, d) and covariances (n, d, d) (Joseph form: symmetric and
    positive definite), and the innovation covariances S = H P H^T + R (n, k, k).

    The matrices are tiny (d, k <= 3), so for a large batch the algebra is written entry by entry
    (each entry an (n,) array): several times faster than batched ``matmul`` and ``inv``.
    """
    if len(mean) < ENTRYWISE_FROM:
        return _update_batched(mean, covariance, residual, jacobian, noise)
    n, d = mean.shape
    p, h = _entries(covariance), _entries(jacobian)
    r = _entries(np.broadcast_to(noise, (n, *np.shape(noise)[-2:])))
    ph_t = _product(p, _transpose(h))  # (d, k)
    s = _sum(_product(h, ph_t), r)
    gain = _product(ph_t, _inverse(s))  # (d, k)
    nu = [residual[:, j] for j in range(residual.shape[1])]
    new_mean = mean + np.stack([_dot(row, nu) for row in gain], -1)
    kh = _product(gain, h)
    identity_minus = [[(1.0 if i == j else 0.0) - kh[i][j] for j in range(d)] for i in range(d)]
    joseph = _product(_product(identity_minus, p), _transpose(identity_minus))
    new_covariance = _sum(joseph, _product(_product(gain, r), _transpose(gain)))
    return new_mean, _array(new_covariance), _array(s)


def _update_batched(mean, covariance, residual, jacobian, noise):
    """``update`` with batched ``matmul`` and ``inv`` (for small batches)."""
    h_t = np.swapaxes(jacobian, -1, -2)
    s = jacobian @ covariance @ h_t + noise
    gain = covariance @ h_t @ np.linalg.inv(s)  # (n, d, k)
    new_mean = mean + np.einsum("nij,nj->ni", gain, residual)
    identity_minus = np.eye(mean.shape[1]) - gain @ jacobian
    joseph = identity_minus @ covariance @ np.swapaxes(identity_minus, -1, -2)
    return new_mean, joseph + gain @ noise @ np.swapaxes(gain, -1, -2), s


def congruence(matrix: np.ndarray, transform: np.ndarray) -> np.ndarray:
    """``A M A^T`` (n, r, r) of a batch of transforms A (n, r, c) and matrices M (c, c) or
    (n, c, c) (covariance propagation), entry by entry like ``update`` for a large batch."""
    if len(transform) < ENTRYWISE_FROM:
        return transform @ matrix @ np.swapaxes(transform, -1, -2)
    a = _entries(transform)
    m = _entries(np.broadcast_to(matrix, (len(transform), *np.shape(matrix)[-2:])))
    return _array(_product(_product(a, m), _transpose(a)))


# Small matrices over a batch, entry by entry: a matrix (n, r, c) is r lists of c arrays (n,).
def _entries(matrix: np.ndarray) -> list[list[np.ndarray]]:
    return [[matrix[:, i, j] for j in range(matrix.shape[2])] for i in range(matrix.shape[1])]


def _array(matrix: list[list[np.ndarray]]) -> np.ndarray:
    return np.stack([np.stack(row, -1) for row in matrix], -2)


def _dot(u: list[np.ndarray], v: list[np.ndarray]) -> np.ndarray:
    total = u[0] * v[0]
    for x, y in zip(u[1:], v[1:]):
        total = total + x * y
    return total


def _product(a: list[list[np.ndarray]], b: list[list[np.ndarray]]) -> list[list[np.ndarray]]:
    columns = _transpose(b)
    return [[_dot(row, column) for column in columns] for row in a]


def _transpose(a: list[list[np.ndarray]]) -> list[list[np.ndarray]]:
    return [list(column) for column in zip(*a)]


def _sum(a: list[list[np.ndarray]], b: list[list[np.ndarray]]) -> list[list[np.ndarray]]:
    return [[x + y for x, y in zip(row_a, row_b)] for row_a, row_b in zip(a, b)]


def _inverse(s: list[list[np.ndarray]]) -> list[list[np.ndarray]]:
    """Inverse of a 1x1 or 2x2 batch, in closed form."""
    if len(s) == 1:
        return [[1.0 / s[0][0]]]
    det = s[0][0] * s[1][1] - s[0][1] * s[1][0]
    return [[s[1][1] / det, -s[0][1] / det], [-s[1][0] / det, s[0][0] / det]]


def sample_gaussians(mean: np.ndarray, covariance: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """One draw from each Gaussian N(mean (n, d), covariance (n, d, d)): (n, d). Uses the
    eigendecomposition, so a covariance that is only positive semi-definite (a pose that has not
    moved) is fine."""
    values, vectors = np.linalg.eigh(covariance)
    draws = rng.standard_normal(mean.shape) * np.sqrt(np.clip(values, 0, None))
    return mean + np.einsum("nij,nj->ni", vectors, draws)
