"""The laser odometry's scan match as it was written before its compiled kernels: numpy and a k-d
tree (scipy's ``cKDTree``) per Gauss-Newton iteration, and the reference scan's surface normals. The oracle that
``mazeslam.registration.kernels`` is tested against (tests/registration/test_icp_kernels.py):
the same objective, the same nearest neighbours, the sums in another order."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from mazeslam.core.geometry import transform_points
from mazeslam.registration.scan_matching import (
    Match,
    ReferenceScan,
    ScanMatchParams,
    _data_scale,
    _prior_offset,
)


def surface_normals(points: np.ndarray, neighbours: int, max_flatness: float) -> tuple[np.ndarray, np.ndarray]:
    """``kernels.surface_normals`` in numpy: the normals (N, 2) and straightness (N,) of ``points``
    (N, 2) by a k-d tree's ``neighbours`` nearest and numpy's eigh."""
    _, nearest = cKDTree(points).query(points, k=neighbours)
    spread = points[nearest] - points[nearest].mean(axis=1, keepdims=True)
    values, vectors = np.linalg.eigh(np.einsum("nki,nkj->nij", spread, spread))
    return vectors[:, :, 0], values[:, 0] <= max_flatness * np.maximum(values[:, 1], 1e-12)


def match_scan(
    reference: ReferenceScan,
    points: np.ndarray,
    prior: np.ndarray,
    prior_covariance: np.ndarray,
    params: ScanMatchParams,
    start: np.ndarray | None = None,
) -> Match:
    """``scan_matching.match_scan`` in numpy."""
    tree = cKDTree(reference.points)
    pose = np.array(prior if start is None else start, dtype=float)
    prior_information = np.linalg.inv(prior_covariance)
    scale = _data_scale(points, params)
    for distance in params.correspondence_distances:
        for _ in range(params.iterations_per_stage):
            jacobian, residual, weight = _paired_terms(reference, tree, points, pose, distance, scale, params)
            offset = _prior_offset(pose, prior)
            hessian = (jacobian * weight[:, None]).T @ jacobian + prior_information
            gradient = (jacobian * weight[:, None]).T @ residual + prior_information @ offset
            pose = pose - np.linalg.solve(hessian, gradient)
            pose[2] = float(np.pi - np.mod(np.pi - pose[2], 2 * np.pi))
    return _score(reference, tree, points, pose, prior, prior_information, params)


def match_information(
    reference: ReferenceScan, points: np.ndarray, pose: np.ndarray, params: ScanMatchParams
) -> np.ndarray:
    """``scan_matching.match_information`` in numpy."""
    last = params.correspondence_distances[-1]
    tree = cKDTree(reference.points)
    jacobian, _, weight = _paired_terms(reference, tree, points, pose, last, _data_scale(points, params), params)
    return (jacobian * weight[:, None]).T @ jacobian


def _paired_terms(reference, tree, points, pose, distance, scale, params):
    """Jacobian rows (M, 3), distances along the normal (M,) m and Huber weights (M,) of the points
    whose nearest reference point lies within ``distance`` (m) on a straight surface."""
    moved = transform_points(pose, points)
    gap, nearest = tree.query(moved, distance_upper_bound=distance)
    used = np.isfinite(gap)
    used[used] = reference.straight[nearest[used]]
    normal = reference.normals[nearest[used]]
    residual = np.einsum("ij,ij->i", moved[used] - reference.points[nearest[used]], normal)
    arm = moved[used] - pose[:2]
    jacobian = np.column_stack([normal, normal[:, 1] * arm[:, 0] - normal[:, 0] * arm[:, 1]])
    weight = scale / np.maximum(1.0, np.abs(residual) / params.point_noise)
    return jacobian, residual, weight


def _score(reference, tree, points, pose, prior, prior_information, params) -> Match:
    """The objective with unpaired points capped, and the overlap."""
    cap = params.correspondence_distances[-1]
    moved = transform_points(pose, points)
    gap, nearest = tree.query(moved)
    residual = np.einsum("ij,ij->i", moved - reference.points[nearest], reference.normals[nearest])
    paired = gap <= cap
    offset = _prior_offset(pose, prior)
    data = np.sum(np.where(paired, np.minimum(residual**2, cap**2), cap**2)) * _data_scale(points, params)
    return Match(pose, float(data + offset @ prior_information @ offset), float(np.mean(paired)))
