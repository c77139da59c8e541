"""Pieces the batch least-squares solvers share (the corner smoother, ``mazeslam.smoothing.smoother``,
and the pose graph, ``mazeslam.posegraph``): the relative-pose factor's residual and Jacobians, and
dense Jacobian blocks placed in a sparse matrix."""

from __future__ import annotations

import numpy as np

from mazeslam.core.geometry import relative, wrap_angle


def relative_pose_residual(
    from_poses: np.ndarray, to_poses: np.ndarray, measured: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Residual of relative-pose factors: ``relative(from, to) - measured``, heading wrapped.

    Args:
        from_poses, to_poses: (n, 3) poses, world frame.
        measured: (n, 3) measured relative poses, in the frame of ``from_poses``.
    Returns:
        residual (n, 3): dx, dy (m) in the frame of ``from_poses``, dth (rad);
        j_from (n, 3, 3): d residual / d from_pose;
        j_to (n, 3, 3): d residual / d to_pose.
    """
    residual = relative(from_poses, to_poses) - measured
    residual[:, 2] = wrap_angle(residual[:, 2])
    cos_a, sin_a = np.cos(from_poses[:, 2]), np.sin(from_poses[:, 2])
    dx, dy = to_poses[:, 0] - from_poses[:, 0], to_poses[:, 1] - from_poses[:, 1]
    j_to = np.zeros((len(dx), 3, 3))
    j_to[:, 0, 0], j_to[:, 0, 1], j_to[:, 1, 0], j_to[:, 1, 1] = cos_a, sin_a, -sin_a, cos_a
    j_to[:, 2, 2] = 1.0
    j_from = -j_to
    j_from[:, 0, 2] = -sin_a * dx + cos_a * dy
    j_from[:, 1, 2] = -cos_a * dx - sin_a * dy
    return residual, j_from, j_to


def block_entries(blocks: np.ndarray, first_rows: np.ndarray, first_columns: np.ndarray):
    """Rows, columns and values (each (n a b,)) of dense blocks (n, a, b) placed at (first_rows[i],
    first_columns[i]) in a sparse matrix (``scipy.sparse.coo_array((values, (rows, columns)))``)."""
    _, a, b = blocks.shape
    rows = np.broadcast_to(first_rows[:, None, None] + np.arange(a)[None, :, None], blocks.shape)
    columns = np.broadcast_to(first_columns[:, None, None] + np.arange(b)[None, None, :], blocks.shape)
    return rows.ravel(), columns.ravel(), blocks.ravel()
