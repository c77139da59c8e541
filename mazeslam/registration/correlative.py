"""Correlative scan matching (Olson, "Real-time correlative scan matching", ICRA 2009): an exhaustive
search over a window of poses, for the intervals where no odometry says roughly how the robot moved.

The previous scan's points are drawn into a likelihood grid: each cell holds
``log(exp(-d^2 / (2 sigma^2)) + floor)``, d the distance (m) from the cell to the nearest point. A
candidate pose of the current scan scores the sum of that grid over its points plus the motion
prior's log density; every pose on a grid of turns and shifts within the window is scored at once
(broadcasting over shifts for each turn). The best few seed the ICP refinement in
``mazeslam.registration.scan_matching``, which is local and would stay in a wrong basin on its own.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mazeslam.core.config import require
from mazeslam.core.geometry import wrap_angle


@dataclass(frozen=True)
class CorrelativeParams:
    """The search window and its grid (TOML section ``[scan_matching.correlative]``).

    Attributes:
        resolution: cell size of the likelihood grid and step of the shifts, m.
        sigma: spread of a point's likelihood, m.
        turn_step: step of the turns searched, degrees.
        window_sigmas: the window reaches this many prior standard deviations from the prior's mean
            (in x, y and heading).
        candidates: best poses handed on for refinement.
        max_points: the search scores at most this many of the scan's points (evenly spaced).
    """

    resolution: float = 0.2
    sigma: float = 0.2
    turn_step: float = 3.0
    window_sigmas: float = 2.5
    candidates: int = 5
    max_points: int = 90

    def __post_init__(self):
        require(
            self.resolution >= 0.001 and self.sigma > 0 and self.turn_step >= 0.01,
            f"resolution must be >= 0.001 m, sigma positive and turn_step >= 0.01 degrees, got "
            f"{self.resolution}, {self.sigma}, {self.turn_step}",
        )
        require(0 < self.window_sigmas <= 100, f"window_sigmas must be in (0, 100], got {self.window_sigmas}")
        require(
            1 <= self.candidates <= 1000 and 1 <= self.max_points <= 100_000,
            "candidates must be in 1..1000 and max_points in 1..100000",
        )


class LikelihoodGrid:
    """``log(exp(-d^2 / (2 sigma^2)) + FLOOR)`` on a grid around ``points`` (N, 2), d the distance
    to the nearest point (m); a point off the grid scores ``log(FLOOR)`` (the grid's border)."""

    #: Likelihood of a point far from every reference point: one stray point cannot veto a pose.
    FLOOR = 0.01

    def __init__(self, points: np.ndarray, params: CorrelativeParams):
        margin = 3 * params.sigma
        self.resolution = params.resolution
        self.origin = points.min(axis=0) - margin - params.resolution  # one border cell beyond the margin
        shape = np.ceil((points.max(axis=0) + margin - self.origin) / params.resolution).astype(int) + 2
        occupied = np.ones(shape, dtype=bool)
        cells = np.floor((points - self.origin) / params.resolution).astype(int)
        occupied[cells[:, 0], cells[:, 1]] = False
        from scipy.ndimage import distance_transform_edt  # 0.25 s to import: only when a search runs

        distance = distance_transform_edt(occupied) * params.resolution
        self.log_values = np.log(np.exp(-0.5 * (distance / params.sigma) ** 2) + self.FLOOR)
        self.log_values[[0, -1], :] = self.log_values[:, [0, -1]] = math.log(self.FLOOR)

    def cells(self, points: np.ndarray) -> np.ndarray:
        """The cell (..., 2) of each of ``points`` (..., 2), metres in the grid's frame."""
        return np.floor((points - self.origin) / self.resolution).astype(int)

    def score(self, cells: np.ndarray) -> np.ndarray:
        """Sum of the grid over the last-but-one axis of ``cells`` (..., K, 2); cells off the grid
        count as its border."""
        rows = np.clip(cells[..., 0], 0, self.log_values.shape[0] - 1)
        columns = np.clip(cells[..., 1], 0, self.log_values.shape[1] - 1)
        return self.log_values[rows, columns].sum(axis=-1)


def correlative_candidates(
    grid: LikelihoodGrid, points: np.ndarray, prior: np.ndarray, prior_covariance: np.ndarray, params: CorrelativeParams
) -> np.ndarray:
    """The ``params.candidates`` best poses (C, 3) of ``points`` (K, 2) (robot frame) in the
    reference scan's frame, best first and one per basin, over the window around ``prior`` (3,).

    Score: the grid summed over the points, scaled to 100 points, minus half the prior's
    Mahalanobis distance with ``prior_covariance`` (3, 3). Shifts are whole cells, so a turn's
    points are placed on the grid once and every shift adds a cell offset.
    """
    points = points[:: -(-len(points) // params.max_points)]
    spread = np.sqrt(np.diag(prior_covariance)) * params.window_sigmas
    reach = np.ceil(spread[:2] / params.resolution).astype(int)
    offsets = np.stack(
        np.meshgrid(np.arange(-reach[0], reach[0] + 1), np.arange(-reach[1], reach[1] + 1), indexing="ij"), axis=-1
    ).reshape(-1, 2)  # (T, 2) cells
    shifts = prior[:2] + offsets * params.resolution  # (T, 2) metres
    turn_span = min(spread[2], math.pi)
    turns = prior[2] + np.arange(-turn_span, turn_span + 1e-9, math.radians(params.turn_step))
    information = np.linalg.inv(prior_covariance)
    scale = 100.0 / len(points)
    shift_penalty = 0.5 * np.einsum("ti,ij,tj->t", shifts - prior[:2], information[:2, :2], shifts - prior[:2])
    pose_blocks: list[np.ndarray] = []
    score_blocks: list[np.ndarray] = []
    for turn in turns:
        cos_t, sin_t = math.cos(turn), math.sin(turn)
        placed = grid.cells(points @ np.array([[cos_t, sin_t], [-sin_t, cos_t]]) + prior[:2])  # (K, 2)
        fit = grid.score(placed[None] + offsets[:, None]) * scale  # (T,)
        turn_offset = wrap_angle(turn - prior[2])
        cross = (shifts - prior[:2]) @ information[:2, 2] * turn_offset
        score = fit - shift_penalty - cross - 0.5 * information[2, 2] * turn_offset**2
        best = np.argsort(score)[-params.candidates :]
        pose_blocks.append(np.column_stack([shifts[best], np.full(len(best), wrap_angle(turn))]))
        score_blocks.append(score[best])
    poses, scores = np.concatenate(pose_blocks), np.concatenate(score_blocks)
    return _distinct(poses[np.argsort(scores)[::-1]], params)


def _distinct(ranked: np.ndarray, params: CorrelativeParams) -> np.ndarray:
    """From poses (N, 3) ranked best first, the best ``params.candidates`` that are not neighbours
    of a better one (within two cells and two turn steps): one seed per basin."""
    chosen: list[np.ndarray] = []
    for pose in ranked:
        if all(
            np.hypot(*(pose[:2] - other[:2])) > 2 * params.resolution
            or abs(wrap_angle(pose[2] - other[2])) > math.radians(2 * params.turn_step)
            for other in chosen
        ):
            chosen.append(pose)
            if len(chosen) == params.candidates:
                break
    return np.array(chosen)
