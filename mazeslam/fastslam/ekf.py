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


class NotPositiveDefinite(ValueError):
    """An innovation covariance S = H P H^T + R that is not positive definite (or is NaN), found
    before it is inverted: the filter's numbers have gone bad (``FastSLAM`` names the settings)."""


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
    z_hat, h_landmark = range_bearing_landmark(poses, landmarks)
    h_pose = np.empty((len(poses), 2, 3))
    h_pose[:, :, :2] = -h_landmark
    h_pose[:, 0, 2], h_pose[:, 1, 2] = 0.0, -1.0
    return z_hat, h_landmark, h_pose


def range_bearing_landmark(poses: np.ndarray, landmarks: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``range_bearing``'s z_hat (n, 2) and h_landmark (n, 2, 2) only (a landmark's own update)."""
    delta = landmarks - poses[:, :2]
    dx, dy = delta[:, 0], delta[:, 1]
    q = np.maximum(dx * dx + dy * dy, 1e-12)
    rho = np.sqrt(q)
    z_hat = np.empty((len(poses), 2))
    z_hat[:, 0], z_hat[:, 1] = rho, wrap(np.arctan2(dy, dx) - poses[:, 2])
    h_landmark = np.empty((len(poses), 2, 2))
    h_landmark[:, 0, 0], h_landmark[:, 0, 1] = dx / rho, dy / rho
    h_landmark[:, 1, 0], h_landmark[:, 1, 1] = -dy / q, dx / q
    return z_hat, h_landmark


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
    Raises ``NotPositiveDefinite`` when an S is not positive definite (a covariance or noise gone
    bad: nothing is inverted then, so no numpy warning).

    The matrices are tiny (d, k <= 3), so for a large batch the algebra is written entry by entry,
    the batch last (``_product``: a few numpy calls over all entries at once): several times faster
    than batched ``matmul`` and ``inv``.
    """
    if len(mean) < ENTRYWISE_FROM:
        return _update_batched(mean, covariance, residual, jacobian, noise)
    d = mean.shape[1]
    p, h, r = _batch_last(covariance), _batch_last(jacobian), _batch_last(noise)
    ph_t = _product(p, _transpose(h))  # (d, k, n)
    s = _product(h, ph_t) + r
    gain = _product(ph_t, _inverse(s, _checked_determinant(s)))  # (d, k, n)
    nu = residual.T  # (k, n)
    step = gain[:, 0] * nu[0]
    for j in range(1, len(nu)):
        step = step + gain[:, j] * nu[j]
    identity_minus = np.eye(d)[:, :, None] - _product(gain, h)
    joseph = _product(_product(identity_minus, p), _transpose(identity_minus))
    new_covariance = joseph + _product(_product(gain, r), _transpose(gain))
    return mean + step.T, _batch_first(new_covariance), _batch_first(s)


def _update_batched(mean, covariance, residual, jacobian, noise):
    """``update`` with batched ``matmul`` and ``inv`` (for small batches)."""
    h_t = np.swapaxes(jacobian, -1, -2)
    s = jacobian @ covariance @ h_t + noise
    _checked_determinant(np.moveaxis(s, 0, -1))
    gain = covariance @ h_t @ np.linalg.inv(s)  # (n, d, k)
    new_mean = mean + np.einsum("nij,nj->ni", gain, residual)
    identity_minus = np.eye(mean.shape[1]) - gain @ jacobian
    joseph = identity_minus @ covariance @ np.swapaxes(identity_minus, -1, -2)
    return new_mean, joseph + gain @ noise @ np.swapaxes(gain, -1, -2), s


def _checked_determinant(s: np.ndarray) -> np.ndarray:
    """The determinants (n,) of the 1x1 or 2x2 innovation covariances ``s`` (k, k, n); raises
    ``NotPositiveDefinite`` unless all are positive (NaN is not). With the landmark and pose
    covariances positive semi-definite and the noise positive definite (``FastSLAM`` checks them
    where they are made), S's diagonal is positive, so only its determinant can fail, to rounding
    or underflow: one reduction per update."""
    determinant = s[0, 0] if len(s) == 1 else s[0, 0] * s[1, 1] - s[0, 1] * s[1, 0]
    if not determinant.min(initial=np.inf) > 0:
        raise NotPositiveDefinite("an innovation covariance (H P H^T + R) is not positive definite")
    return determinant


def positive_definite(leading: np.ndarray, determinant: np.ndarray) -> bool:
    """Whether the 2x2 (or 1x1) matrices with leading entries ``leading`` (n,) and determinants
    ``determinant`` (n,) are all positive definite (Sylvester's criterion; NaN fails, inf is not
    looked for: the filter's inputs are finite). Two reductions, no temporaries: cheap enough for
    every update."""
    return bool(leading.min(initial=np.inf) > 0 and determinant.min(initial=np.inf) > 0)


def congruence(matrix: np.ndarray, transform: np.ndarray) -> np.ndarray:
    """``A M A^T`` (n, r, r) of a batch of transforms A (n, r, c) and matrices M (c, c) or
    (n, c, c) (covariance propagation), entry by entry like ``update`` for a large batch."""
    if len(transform) < ENTRYWISE_FROM:
        return transform @ matrix @ np.swapaxes(transform, -1, -2)
    a = _batch_last(transform)
    return _batch_first(_product(_product(a, _batch_last(matrix)), _transpose(a)))


# Small matrices over a batch, entry by entry: a batch of n (r, c) matrices is held as an (r, c, n)
# array, batch last, so that each step below is one numpy call over all entries of the batch.
def _batch_last(matrix: np.ndarray) -> np.ndarray:
    """(n, r, c) -> (r, c, n); one matrix (r, c) -> (r, c, 1), the same for every member."""
    matrix = np.asarray(matrix)
    return matrix[:, :, None] if matrix.ndim == 2 else np.ascontiguousarray(np.moveaxis(matrix, 0, -1))


def _batch_first(matrix: np.ndarray) -> np.ndarray:
    """(r, c, n) -> (n, r, c)."""
    return np.moveaxis(matrix, -1, 0)


def _product(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Matrix products (r, c, n) of batches a (r, m, n) and b (m, c, n), n contiguous (either n may
    be 1): one ``einsum``, each entry summed over m in order, as a loop over the entries would (the
    same bits with numpy 2.4 here; about twice as fast as a broadcast product per term). Not for
    views whose last axis is strided: einsum then takes a path several times slower."""
    return np.einsum("im...,mj...->ij...", a, b)


def _transpose(a: np.ndarray) -> np.ndarray:
    return a.transpose(1, 0, 2)


def _inverse(s: np.ndarray, det: np.ndarray) -> np.ndarray:
    """Inverse of a batch of 1x1 or 2x2 matrices (k, k, n) of determinants ``det`` (n,), in closed form."""
    if len(s) == 1:
        return 1.0 / s
    return np.stack([np.stack([s[1, 1] / det, -s[0, 1] / det]), np.stack([-s[1, 0] / det, s[0, 0] / det])])


def sample_gaussians(mean: np.ndarray, covariance: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """One draw from each Gaussian N(mean (n, d), covariance (n, d, d)): (n, d). Uses the
    eigendecomposition, so a covariance that is only positive semi-definite (a pose that has not
    moved) is fine."""
    values, vectors = np.linalg.eigh(covariance)
    draws = rng.standard_normal(mean.shape) * np.sqrt(np.clip(values, 0, None))
    return mean + np.einsum("nij,nj->ni", vectors, draws)
