"""Scan matching against an occupancy grid: a likelihood field and Gauss-Newton on it.

The field is the distance ``d`` (m) from a point to the nearest occupied cell (log-odds above
``occupied_threshold``) of a window of the map, exact between cell centres up to ``field_reach``
and clipped there, computed where a lookup reads it. A scan's end points at a robot pose score

    log p(z | m, x) = scale * sum_i log(exp(-d_i^2 / (2 sigma^2)) + floor)

(Thrun et al., Probabilistic Robotics 6.4, the likelihood field; ``floor`` keeps one stray point
from vetoing a pose, ``scale`` tempers the product of beams that are not independent). The pose
that maximises it times the motion prior is found by iteratively reweighted Gauss-Newton on the
bilinearly interpolated distance, from a wide ``sigma`` to the final one, so that the basin is
wide at first and the optimum sharp at last.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from mazeslam.core.config import require
from mazeslam.core.geometry import wrap_angle
from mazeslam.gridslam.occupancy import Window


@dataclass(frozen=True)
class MatchParams:
    """The matcher and the observation model.

    Attributes:
        sigma: spread of an end point's likelihood around the nearest occupied cell, m.
        floor: likelihood of an end point far from every occupied cell.
        sigma_schedule: the Gauss-Newton stages' sigmas, m, coarse to fine (the last should be
            ``sigma``); ``iterations`` per stage.
        max_range: end points farther than this from the sensor are not matched, m.
        max_points: at most this many end points are matched (evenly spaced over the scan).
        occupied_threshold: a cell with log-odds above this is occupied.
        min_overlap: the match is accepted when at least this fraction of the points lies within
            ``overlap_distance`` (m) of an occupied cell at the optimum.
        scale: the log-likelihood's multiplier, per matched point (1: independent beams).
    """

    sigma: float = 0.05
    floor: float = 0.05
    sigma_schedule: tuple = (0.3, 0.15, 0.05)
    iterations: int = 4
    max_range: float = 20.0
    max_points: int = 180
    occupied_threshold: float = 0.0
    min_overlap: float = 0.4
    overlap_distance: float = 0.15
    scale: float = 1.0

    def __post_init__(self):
        object.__setattr__(self, "sigma_schedule", tuple(self.sigma_schedule))
        require(
            self.sigma > 0 and self.floor > 0 and all(s > 0 for s in self.sigma_schedule),
            "sigma, floor and sigma_schedule must be positive",
        )
        require(self.iterations >= 1 and self.max_points >= 3, "need iterations >= 1 and max_points >= 3")
        require(0 <= self.min_overlap <= 1, "min_overlap must be a fraction")


#: How far the likelihood field is searched, in sigmas of the widest stage: a point 5 sigmas from
#: every wall has likelihood exp(-12.5) ~ 4e-6, far below any ``floor``, so its score and its weight in
#: the Gauss-Newton step (about 1e-4 of a point on a wall at a floor of 0.05) do not depend on how
#: much farther the wall is. The field is clipped there, and the search for a cell's wall ends there.
FIELD_REACH_SIGMAS = 5.0


def field_reach(params: MatchParams, resolution: float) -> float:
    """The distance (cells of ``resolution`` m) at which the likelihood field is clipped:
    ``FIELD_REACH_SIGMAS`` times the widest sigma of the match, at least ``overlap_distance`` and
    one cell past it (so that the overlap's test is never clipped)."""
    widest = max(params.sigma, *params.sigma_schedule)
    return max(FIELD_REACH_SIGMAS * widest, params.overlap_distance + resolution) / resolution


class DistanceMemo:
    """Buffers for the cells' distances a ``LikelihoodField`` has computed, reused from field to
    field so that none is cleared: a cell's distance (float32, cells) is valid where its stamp
    (int32) is the field's."""

    def __init__(self):
        self.distances, self.stamps, self.stamp = np.empty(0, dtype=np.float32), np.empty(0, dtype=np.int32), 0

    def claim(self, cells: int) -> tuple[np.ndarray, np.ndarray, int]:
        """Buffers of at least ``cells`` and a new stamp (nothing in them is valid for it yet)."""
        if len(self.distances) < cells:
            self.distances, self.stamps = np.empty(cells, dtype=np.float32), np.zeros(cells, dtype=np.int32)
        self.stamp += 1
        return self.distances, self.stamps, self.stamp


class LikelihoodField:
    """The distance (m) from a world point to the nearest occupied cell of ``window`` (log-odds above
    ``params.occupied_threshold``), bilinear between cell centres.

    A cell's distance is the exact Euclidean distance between cell centres up to ``field_reach``
    (clipped there), what a distance transform of the whole window gives (OpenCV's
    ``distanceTransform``, ``DIST_MASK_PRECISE``); it
    is computed the first time a lookup reads the cell (``mazeslam.gridslam.kernels.lookup``) and
    kept, so a scan match pays for the few thousand cells around its end points, not for every cell
    of the window. ``memo``: buffers to reuse (one per filter; a field's lookups are valid until the
    next field claims them).
    """

    def __init__(self, window: Window, params: MatchParams, memo: DistanceMemo | None = None):
        from mazeslam.gridslam import kernels  # here, not at the top: numba loads only where the grid filter runs

        self.kernels: Any = kernels  # compiled functions: numba's dispatchers are not typed by their Python signature
        self.values = window.values  # float32, (X, Y); a view into a larger window is read in place
        self.threshold = float(params.occupied_threshold)
        self.has_occupied = bool(kernels.any_occupied(self.values, self.threshold))
        self.origin = np.asarray(window.origin, dtype=float)
        self.resolution = float(window.resolution)
        self.reach = field_reach(params, self.resolution)
        self.blocks = kernels.empty_blocks(*self.values.shape)  # occupied cells by block, listed as searches need them
        self.memo = (memo or DistanceMemo()).claim(self.values.size)

    @property
    def kernel_field(self) -> tuple:
        """The window and its memo as the distance kernels take them (``mazeslam.gridslam.kernels``)."""
        return self.values, self.threshold, self.blocks, *self.memo, self.origin, self.resolution, self.reach

    def occupied_points(self) -> np.ndarray:
        """World positions (M, 2) of the occupied cells' centres, m."""
        return self.origin + (np.argwhere(self.values > self.threshold) + 0.5) * self.resolution

    def lookup(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Bilinear distance (...,) m at world ``points`` (..., 2) m and its gradient (..., 2), m/m.
        Points outside the cell centres' grid are interpolated between its two outermost rows or
        columns with their own fraction of a cell (``mazeslam.gridslam.kernels.lookup``)."""
        flat = np.ascontiguousarray(points, dtype=float).reshape(-1, 2)
        value, gradient = np.empty(len(flat)), np.empty((len(flat), 2))
        self.kernels.lookup(self.kernel_field, flat, value, gradient)
        return value.reshape(points.shape[:-1]), gradient.reshape(points.shape)

    def log_likelihood(self, poses: np.ndarray, points: np.ndarray, params: MatchParams) -> np.ndarray:
        """``log p(z | m, x)`` (K,) of end points ``points`` (N, 2) (robot frame) at ``poses`` (K, 3)."""
        poses = np.ascontiguousarray(poses, dtype=float)
        return self.kernels.objective(
            self.kernel_field,
            poses,
            _points(points),
            np.zeros(3),
            np.zeros((3, 3)),
            params.sigma,
            params.scale,
            params.floor,
        )

    def objective(
        self,
        poses: np.ndarray,
        points: np.ndarray,
        prior: np.ndarray,
        prior_information: np.ndarray,
        params: MatchParams,
    ) -> np.ndarray:
        """``log p(z | m, x)`` plus the Gaussian prior's log density (up to a constant) at ``poses`` (K, 3)."""
        offsets = poses - prior
        offsets[:, 2] = wrap_angle(offsets[:, 2])
        penalty = 0.5 * np.einsum("ki,ij,kj->k", offsets, prior_information, offsets)
        return self.log_likelihood(poses, points, params) - penalty

    def overlap(self, pose: np.ndarray, points: np.ndarray, params: MatchParams) -> float:
        """Fraction of ``points`` (N, 2) (robot frame) within ``overlap_distance`` of an occupied cell."""
        pose = np.asarray(pose, dtype=float)
        return float(self.kernels.overlap(self.kernel_field, pose, _points(points), params.overlap_distance))


def _points(points: np.ndarray) -> np.ndarray:
    """``points`` (N, 2) as the kernels take them: float64, C-contiguous."""
    return np.ascontiguousarray(points, dtype=float)


def match_points(ranges: np.ndarray, bearings: np.ndarray, mount: np.ndarray, params: MatchParams) -> np.ndarray:
    """The end points (K, 2) to match, robot frame (m): returns within ``max_range``, thinned evenly
    to at most ``max_points``."""
    valid = (ranges > 0) & (ranges <= params.max_range)
    points = mount + ranges[valid, None] * np.column_stack([np.cos(bearings[valid]), np.sin(bearings[valid])])
    return points[:: -(-len(points) // params.max_points)] if len(points) else points


def refine_pose(
    field: LikelihoodField,
    points: np.ndarray,
    prior: np.ndarray,
    prior_information: np.ndarray,
    params: MatchParams,
    start: np.ndarray | None = None,
) -> np.ndarray:
    """The pose (3,) maximising the likelihood of ``points`` (N, 2) (robot frame) times the Gaussian
    motion prior (mean ``prior`` (3,), information (3, 3)), from ``start`` (default ``prior``).

    Each stage of ``sigma_schedule`` runs ``iterations`` Gauss-Newton steps on the residuals
    ``d_i`` weighted by ``rho'(d_i) / d_i`` of ``rho(d) = -log(exp(-d^2 / (2 s^2)) + floor)``: points
    near a wall weigh ``1 / s^2``, points far from all walls nothing (``kernels.refine``).
    """
    start = np.array(prior if start is None else start, dtype=float)
    arguments = (*_prior(points, prior, prior_information), kernel_settings(params), start)
    return field.kernels.refine(field.kernel_field, *arguments)


def match_pose(
    field: LikelihoodField, points: np.ndarray, prior: np.ndarray, prior_information: np.ndarray, params: MatchParams
) -> tuple[np.ndarray, float]:
    """``refine_pose`` from ``prior`` and the ``overlap`` of the result: the pose (3,) and the
    share of ``points`` (N, 2) within ``overlap_distance`` of an occupied cell there."""
    arguments = (*_prior(points, prior, prior_information), kernel_settings(params), params.overlap_distance)
    pose, share = field.kernels.match(field.kernel_field, *arguments)
    return pose, float(share)


def _prior(points: np.ndarray, prior: np.ndarray, information: np.ndarray) -> tuple:
    """End points (N, 2), the prior's mean (3,) and information (3, 3) as the kernels take them."""
    return _points(points), np.asarray(prior, dtype=float), np.ascontiguousarray(information, dtype=float)


def kernel_settings(params: MatchParams) -> tuple:
    """The refinement's settings as ``kernels.refine`` takes them: (sigmas (S,) m, iterations,
    scale, floor)."""
    return np.asarray(params.sigma_schedule, dtype=float), params.iterations, params.scale, params.floor
