"""Scan matching against an occupancy grid: a likelihood field and Gauss-Newton on it.

The field is the distance ``d`` (m) from every cell of a window to the nearest occupied cell (log-odds
above ``occupied_threshold``), from OpenCV's exact Euclidean distance transform. A scan's end points
at a robot pose score

    log p(z | m, x) = scale * sum_i log(exp(-d_i^2 / (2 sigma^2)) + floor)

(Thrun et al., Probabilistic Robotics 6.4, the likelihood field; ``floor`` keeps one stray point
from vetoing a pose, ``scale`` tempers the product of beams that are not independent). The pose
that maximises it times the motion prior is found by iteratively reweighted Gauss-Newton on the
bilinearly interpolated distance, from a wide ``sigma`` to the final one, so that the basin is
wide at first and the optimum sharp at last.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mazeslam.core.config import require
from mazeslam.core.geometry import transform_points, wrap_angle
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


class LikelihoodField:
    """The distance (m) from each cell of ``window`` to its nearest occupied cell, interpolated."""

    def __init__(self, window: Window, params: MatchParams):
        import cv2  # here, not at the top: the slam config names the grid's settings, and OpenCV is slow to load

        self.occupied = window.values > params.occupied_threshold
        free = (~self.occupied).astype(np.uint8)
        self.has_occupied = bool(self.occupied.any())
        self.distance = cv2.distanceTransform(free, cv2.DIST_L2, cv2.DIST_MASK_PRECISE) * window.resolution
        self.origin, self.resolution = window.origin, window.resolution

    def occupied_points(self) -> np.ndarray:
        """World positions (M, 2) of the occupied cells' centres, m."""
        return self.origin + (np.argwhere(self.occupied) + 0.5) * self.resolution

    def lookup(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Bilinear distance (...,) at world ``points`` (..., 2) and its gradient (..., 2), m/m.
        Points outside the window take the nearest border cells."""
        cell = (points - self.origin) / self.resolution - 0.5  # cell centres at integers
        base = np.floor(cell)
        frac = cell - base
        limit = np.array(self.distance.shape) - 2
        i = np.clip(base[..., 0].astype(int), 0, limit[0])
        j = np.clip(base[..., 1].astype(int), 0, limit[1])
        d00, d10 = self.distance[i, j], self.distance[i + 1, j]
        d01, d11 = self.distance[i, j + 1], self.distance[i + 1, j + 1]
        fx, fy = frac[..., 0], frac[..., 1]
        value = (d00 * (1 - fx) + d10 * fx) * (1 - fy) + (d01 * (1 - fx) + d11 * fx) * fy
        gradient_x = ((d10 - d00) * (1 - fy) + (d11 - d01) * fy) / self.resolution
        gradient_y = ((d01 - d00) * (1 - fx) + (d11 - d10) * fx) / self.resolution
        return value, np.stack([gradient_x, gradient_y], axis=-1)

    def log_likelihood(self, poses: np.ndarray, points: np.ndarray, params: MatchParams) -> np.ndarray:
        """``log p(z | m, x)`` (K,) of end points ``points`` (N, 2) (robot frame) at ``poses`` (K, 3)."""
        cos_t, sin_t = np.cos(poses[:, 2:3]), np.sin(poses[:, 2:3])
        world = np.stack(
            [
                poses[:, :1] + cos_t * points[:, 0] - sin_t * points[:, 1],
                poses[:, 1:2] + sin_t * points[:, 0] + cos_t * points[:, 1],
            ],
            axis=-1,
        )
        distance, _ = self.lookup(world)
        return params.scale * np.log(np.exp(-0.5 * (distance / params.sigma) ** 2) + params.floor).sum(axis=-1)

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
        distance, _ = self.lookup(transform_points(pose, points))
        return float(np.mean(distance <= params.overlap_distance))


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
    near a wall weigh ``1 / s^2``, points far from all walls nothing.
    """
    pose = np.array(prior if start is None else start, dtype=float)
    for sigma in params.sigma_schedule:
        for _ in range(params.iterations):
            cos_t, sin_t = np.cos(pose[2]), np.sin(pose[2])
            arm = np.column_stack(
                [cos_t * points[:, 0] - sin_t * points[:, 1], sin_t * points[:, 0] + cos_t * points[:, 1]]
            )
            distance, gradient = field.lookup(pose[:2] + arm)
            jacobian = np.column_stack([gradient, gradient[:, 1] * arm[:, 0] - gradient[:, 0] * arm[:, 1]])
            likelihood = np.exp(-0.5 * (distance / sigma) ** 2)
            weight = params.scale * likelihood / (likelihood + params.floor) / sigma**2
            offset = pose - prior
            offset[2] = wrap_angle(offset[2])
            hessian = (jacobian * weight[:, None]).T @ jacobian + prior_information
            step = np.linalg.solve(hessian, (jacobian * weight[:, None]).T @ distance + prior_information @ offset)
            pose -= step
            pose[2] = wrap_angle(pose[2])
    return pose
