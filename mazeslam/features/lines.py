"""Line extraction from a range scan: the exercise's line fit and split-and-merge (Part A, Algorithm 1).

A line is kept in polar form ``x cos(alpha) + y sin(alpha) = r`` with ``r >= 0`` and
``-pi < alpha <= pi`` (the exercise's Fig 2). ``fit_line`` minimises the squared perpendicular
distances (total least squares) exactly as the exercise derives it::

    nom   = -2 sum_i (x_i - x_c)(y_i - y_c)
    denom =    sum_i (y_i - y_c)^2 - (x_i - x_c)^2
    alpha = 0.5 atan2(nom, denom)
    r     = x_c cos(alpha) + y_c sin(alpha)        (the centroid lies on the line)

Split-and-merge works on runs of consecutive valid beams. Any subset's sums come from prefix sums
in constant time, so a fit costs a few float operations however many points it covers.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mazeslam.core.config import require


@dataclass(frozen=True)
class LineParams:
    """Split-and-merge settings; lengths in metres, angles in degrees.

    Attributes:
        split_threshold: a set whose farthest point lies farther than this from its fitted line
            is split (Algorithm 1, step 4).
        merge_threshold: neighbouring segments whose joint fit keeps every point within this are
            merged (step 6).
        min_points: segments with fewer points are dropped.
        min_length: segments shorter than this (between their projected end points) are dropped.
        breakpoint_angle: lambda of the adaptive breakpoint detector (Borges & Aldon 2004): two
            neighbouring points farther apart than ``r sin(step) / sin(lambda - step) + 3 sigma``
            are on different surfaces. Smaller lambda: more tolerant of grazing walls.
        range_noise_std: sigma, the sensor's range noise; it also floors the fit's noise estimate.
    """

    split_threshold: float = 0.012
    merge_threshold: float = 0.012
    min_points: int = 5
    min_length: float = 0.03
    breakpoint_angle: float = 10.0
    range_noise_std: float = 0.003

    def __post_init__(self):
        require(self.split_threshold > 0, f"split_threshold must be positive, got {self.split_threshold}")
        require(self.merge_threshold > 0, f"merge_threshold must be positive, got {self.merge_threshold}")
        require(2 <= self.min_points <= 100_000, f"min_points must be in 2..100000, got {self.min_points}")
        require(self.min_length >= 0, f"min_length must be >= 0, got {self.min_length}")
        require(
            0 < self.breakpoint_angle < 90, f"breakpoint_angle must be in (0, 90) degrees, got {self.breakpoint_angle}"
        )
        require(self.range_noise_std >= 0, f"range_noise_std must be >= 0, got {self.range_noise_std}")


def fit_line(points) -> tuple[float, float]:
    """Total-least-squares line ``(r, alpha)`` through ``points`` (n >= 2, shape (n, 2)), metres and radians."""
    points = np.asarray(points, dtype=float)
    if points.ndim != 2 or points.shape[1] != 2 or len(points) < 2:
        raise ValueError(f"fit_line needs at least two points shaped (n, 2), got {points.shape}")
    x, y = points[:, 0], points[:, 1]
    return _line_from_sums(len(points), x.sum(), y.sum(), (x * x).sum(), (y * y).sum(), (x * y).sum())


def _line_from_sums(n, sx, sy, sxx, syy, sxy) -> tuple[float, float]:
    """The exercise's fit from the point count and the sums of x, y, x^2, y^2, xy."""
    xc, yc = sx / n, sy / n
    nom = -2.0 * (sxy - n * xc * yc)
    denom = (syy - n * yc * yc) - (sxx - n * xc * xc)
    alpha = 0.5 * math.atan2(nom, denom)
    r = xc * math.cos(alpha) + yc * math.sin(alpha)
    if r < 0:
        r, alpha = -r, alpha + math.pi
    if alpha > math.pi:
        alpha -= 2 * math.pi
    return float(r), float(alpha)


@dataclass(slots=True)
class LineSegment:
    """A straight piece of wall seen in one scan, in the sensor frame.

    Attributes:
        r, alpha: the fitted line ``x cos(alpha) + y sin(alpha) = r``; metres, radians.
        first, last: positions (inclusive) of its first and last point in the scan's point order.
        start, end: (2,) its first and last point projected onto the line, metres.
        covariance: (2, 2) covariance of ``(r, alpha)`` from the fit (see ``line_covariance``).
        noise_var: the variance of a point's distance to the line used for it, m^2.
    """

    r: float
    alpha: float
    first: int
    last: int
    start: np.ndarray
    end: np.ndarray
    covariance: np.ndarray
    noise_var: float

    @property
    def n_points(self) -> int:
        return self.last - self.first + 1

    @property
    def normal(self) -> np.ndarray:
        return np.array([math.cos(self.alpha), math.sin(self.alpha)])

    @property
    def direction(self) -> np.ndarray:
        """Unit vector along the line, (-sin alpha, cos alpha)."""
        return np.array([-math.sin(self.alpha), math.cos(self.alpha)])

    @property
    def length(self) -> float:
        return math.dist(self.start, self.end)

    def project(self, point) -> np.ndarray:
        """The point of the line nearest to ``point`` (2,)."""
        point = np.asarray(point, dtype=float)
        return point - (point @ self.normal - self.r) * self.normal


class SplitAndMerge:
    """Segments one scan's points into straight lines.

    ``segment(points, runs)`` takes the points (P, 2) in scan order and the runs ``[(first, last),
    ...]`` of positions that may belong together (no gap or jump inside), and returns the
    ``LineSegment``s in scan order.
    """

    def __init__(self, params: LineParams):
        self.params = params

    def segment(self, points: np.ndarray, runs) -> list[LineSegment]:
        p = self.params
        self._points = points
        x, y = points[:, 0], points[:, 1]
        columns = np.column_stack([x, y, x * x, y * y, x * y])
        # Row k: the sums of x, y, x^2, y^2, xy over positions before k (Python floats: fast scalars).
        self._sums = [[0.0] * 5] + np.cumsum(columns, axis=0).tolist()
        spans = []
        for first, last in runs:
            if last - first + 1 >= p.min_points:
                spans.extend(self._split(first, last))
        spans = [span for span in spans if span[1] - span[0] + 1 >= p.min_points]
        spans = self._refine_boundaries(self._merge(spans))
        segments = [self._make_segment(first, last) for first, last in spans]
        return [segment for segment in segments if segment.length >= p.min_length]

    def _fit(self, first: int, last: int) -> tuple[float, float]:
        return _line_from_sums(last - first + 1, *self._subset_sums(first, last))

    def _subset_sums(self, first: int, last: int) -> list[float]:
        """Sums of x, y, x^2, y^2, xy over positions first..last."""
        high, low = self._sums[last + 1], self._sums[first]
        return [high_sum - low_sum for high_sum, low_sum in zip(high, low)]

    def _distances(self, first: int, last: int, r: float, alpha: float) -> np.ndarray:
        return np.abs(self._points[first : last + 1] @ (math.cos(alpha), math.sin(alpha)) - r)

    def _distance(self, k: int, line: tuple[float, float]) -> float:
        """Distance of point k to the line ``(r, alpha)``."""
        x, y = self._points[k].tolist()
        r, alpha = line
        return abs(x * math.cos(alpha) + y * math.sin(alpha) - r)

    def _split(self, first: int, last: int) -> list[tuple[int, int]]:
        """Algorithm 1, steps 2-5: split at the farthest point until every set fits its line.

        The fitted line decides whether to split (as the exercise); the split point is the one
        farthest from the chord between the set's end points, which puts it at the corner even when
        the fitted line of an L-shaped set runs diagonally through it.
        """
        done, todo = [], [(first, last)]
        threshold = self.params.split_threshold
        while todo:
            a, b = todo.pop()
            if b - a < 2 or self._distances(a, b, *self._fit(a, b)).max() <= threshold:
                done.append((a, b))
                continue
            chord = self._points[b] - self._points[a]
            offsets = self._points[a + 1 : b] - self._points[a]
            k = a + 1 + int(np.argmax(np.abs(offsets[:, 0] * chord[1] - offsets[:, 1] * chord[0])))
            todo.extend(reversed(self._split_at(a, k, b)))
        return sorted(done)

    def _split_at(self, a: int, k: int, b: int) -> list[tuple[int, int]]:
        """Split a..b at point k, which joins the side whose line (fitted without it) it is nearer to."""
        if k - a < 2 or b - k < 2:
            return [(a, k), (k + 1, b)]
        to_left = self._distance(k, self._fit(a, k - 1))
        to_right = self._distance(k, self._fit(k + 1, b))
        return [(a, k), (k + 1, b)] if to_left <= to_right else [(a, k - 1), (k, b)]

    def _refine_boundaries(self, spans: list[tuple[int, int]]) -> list[tuple[int, int]]:
        """Move each point at the border of two touching segments to the one whose line is nearer.

        A split point, or the first point of a scan, may sit on the other wall of a corner; left in
        the wrong segment it tilts that segment's line.
        """
        spans = list(spans)
        for i in range(len(spans) - 1):
            (a, b), (c, d) = spans[i], spans[i + 1]
            if c != b + 1 or b - a < 2 or d - c < 2:
                continue
            left, right = self._fit(a, b - 1), self._fit(c + 1, d)
            if self._distance(b, right) < self._distance(b, left):
                spans[i], spans[i + 1] = (a, b - 1), (b, d)
            elif self._distance(c, left) < self._distance(c, right):
                spans[i], spans[i + 1] = (a, c), (c + 1, d)
        return spans

    def _merge(self, spans: list[tuple[int, int]]) -> list[tuple[int, int]]:
        """Algorithm 1, step 6: merge touching neighbours that one line fits."""
        merged = list(spans)
        threshold = self.params.merge_threshold
        changed = True
        while changed:
            changed = False
            for i in range(len(merged) - 1):
                (a, b), (c, d) = merged[i], merged[i + 1]
                if c == b + 1 and self._distances(a, d, *self._fit(a, d)).max() <= threshold:
                    merged[i : i + 2] = [(a, d)]
                    changed = True
                    break
        return merged

    def _make_segment(self, first: int, last: int) -> LineSegment:
        n = last - first + 1
        sx, sy, sxx, syy, sxy = self._subset_sums(first, last)
        r, alpha = _line_from_sums(n, sx, sy, sxx, syy, sxy)
        c, s = math.cos(alpha), math.sin(alpha)
        # Sums of squared residuals and of along-line coordinates s_i = -x_i sin(alpha) + y_i cos(alpha).
        squared = c * c * sxx + 2 * c * s * sxy + s * s * syy - 2 * r * (c * sx + s * sy) + n * r * r
        noise_var = max(squared / max(n - 2, 1), self.params.range_noise_std**2)
        along = -s * sx + c * sy
        along_squared = s * s * sxx - 2 * s * c * sxy + c * c * syy
        covariance = line_covariance(n, along, along_squared, noise_var)
        (x0, y0), (x1, y1) = self._points[first], self._points[last]
        offset0, offset1 = x0 * c + y0 * s - r, x1 * c + y1 * s - r  # distances off the line
        start = np.array([x0 - offset0 * c, y0 - offset0 * s])
        end = np.array([x1 - offset1 * c, y1 - offset1 * s])
        return LineSegment(r, alpha, first, last, start, end, covariance, noise_var)


def line_covariance(n: int, along: float, along_squared: float, noise_var: float) -> np.ndarray:
    """Covariance (2, 2) of a fitted line's ``(r, alpha)`` from its n points.

    A point at along-line coordinate s (along (-sin alpha, cos alpha)) is offset from a line
    perturbed by (dr, dalpha) by ``s dalpha - dr``; least squares over n points with noise
    variance sigma^2 then gives, with S = sum (s_i - mean s)^2::

        var r = sigma^2 (1/n + mean(s)^2 / S),  var alpha = sigma^2 / S,  cov = sigma^2 mean(s) / S

    ``along`` and ``along_squared`` are the sums of s_i and s_i^2.
    """
    mean = along / n
    spread = max(along_squared - n * mean * mean, 1e-12)
    return noise_var * np.array([[1.0 / n + mean * mean / spread, mean / spread], [mean / spread, 1.0 / spread]])
