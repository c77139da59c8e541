"""The "virtual laser": N range beams cast from the robot against the maze's wall surfaces.

The exercise's robot measures ranges with an omnidirectional camera (Exercise 3's "virtual laser");
the simulator models it as an ideal ray caster plus Gaussian range noise and random dropouts. A
range of 0 means "no return" (out of range or dropped), as in the course log format.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mazeslam.beams import BeamGeometry
from mazeslam.config import require
from mazeslam.geometry import compose


@dataclass(frozen=True)
class LaserParams:
    """Virtual laser settings.

    Attributes:
        beams: number of beams over the field of view (the exercise's N; default 180, one per 2 deg).
        max_range: longest range reported, metres; farther walls give 0.
        min_range: shortest range reported, metres; nearer walls give 0 (the camera's blind disc).
        range_noise_std: standard deviation of the Gaussian range noise, metres.
        dropout: probability that a beam returns nothing (0), independent per beam.
        first_beam_angle, direction, field_of_view, mount_x, mount_y: the beam geometry written to
            the log's sidecar (see ``mazeslam.beams.BeamGeometry``); radians and metres.
    """

    beams: int = 180
    max_range: float = 0.8
    min_range: float = 0.0
    range_noise_std: float = 0.003
    dropout: float = 0.0
    first_beam_angle: float = -np.pi
    direction: int = 1
    field_of_view: float = 2 * np.pi
    mount_x: float = 0.0
    mount_y: float = 0.0

    def __post_init__(self):
        require(self.beams >= 1, f"laser beams must be at least 1, got {self.beams}")
        require(self.max_range > 0, f"laser max_range must be positive, got {self.max_range}")
        require(0 <= self.min_range < self.max_range,
                f"laser min_range must be in [0, max_range), got {self.min_range}")
        require(self.range_noise_std >= 0, f"laser range_noise_std must be >= 0, got {self.range_noise_std}")
        require(0 <= self.dropout < 1, f"laser dropout must be in [0, 1), got {self.dropout}")
        self.geometry  # validates direction and field of view

    @property
    def geometry(self) -> BeamGeometry:
        return BeamGeometry(self.first_beam_angle, self.direction, self.field_of_view,
                            self.mount_x, self.mount_y)


def cast_rays(origin: np.ndarray, angles: np.ndarray, segments: np.ndarray, max_range: float) -> np.ndarray:
    """Distance from ``origin`` (2,) along each world angle in ``angles`` (N,) to the first segment hit.

    ``segments`` is (W, 4) ``[x1, y1, x2, y2]``. Walls wholly farther than ``max_range`` are culled
    first. Returns (N,) distances in metres, ``inf`` where no segment lies within ``max_range``.
    """
    origin = np.asarray(origin, dtype=float)
    p = segments[:, :2] - origin
    e = segments[:, 2:] - segments[:, :2]
    segments_near = _segment_distance(p, e) <= max_range
    p, e = p[segments_near], e[segments_near]
    d = np.stack([np.cos(angles), np.sin(angles)], axis=-1)  # (N, 2)
    # Solve origin + t d = p + s e for every (beam, segment) pair with 2-D cross products.
    denom = d[:, None, 0] * e[None, :, 1] - d[:, None, 1] * e[None, :, 0]  # d x e, (N, W)
    p_cross_e = p[:, 0] * e[:, 1] - p[:, 1] * e[:, 0]  # (W,)
    p_cross_d = p[None, :, 0] * d[:, None, 1] - p[None, :, 1] * d[:, None, 0]  # (N, W)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = p_cross_e[None, :] / denom
        s = p_cross_d / denom
    hit = (denom != 0) & (t > 0) & (s >= 0) & (s <= 1)
    distances = np.where(hit, t, np.inf).min(axis=1, initial=np.inf)
    distances[distances > max_range] = np.inf
    return distances


def _segment_distance(p: np.ndarray, e: np.ndarray) -> np.ndarray:
    """Distance from the origin to each segment ``p + s e``, s in [0, 1]; p, e shaped (W, 2)."""
    length2 = np.einsum("ij,ij->i", e, e)
    s = np.clip(-np.einsum("ij,ij->i", p, e) / np.where(length2 > 0, length2, 1), 0, 1)
    closest = p + s[:, None] * e
    return np.hypot(closest[:, 0], closest[:, 1])


class VirtualLaser:
    """Casts the configured beams from a robot pose and returns one noisy scan.

    The beam geometry (``params.geometry``) gives each beam's bearing in the robot frame and the
    sensor's mounting point; ``scan`` returns ranges in beam order, as written to a course log.
    """

    def __init__(self, params: LaserParams, surfaces: np.ndarray):
        self.params = params
        self.surfaces = np.asarray(surfaces, dtype=float).reshape(-1, 4)
        self.bearings = params.geometry.bearings(params.beams)  # (N,) robot frame, radians

    def true_ranges(self, pose: np.ndarray) -> np.ndarray:
        """Noise-free ranges (N,) from robot ``pose`` (x, y, theta), ``inf`` beyond ``max_range``."""
        geometry = self.params.geometry
        sensor = compose(pose, [geometry.mount_x, geometry.mount_y, 0.0])
        return cast_rays(sensor[:2], sensor[2] + self.bearings, self.surfaces, self.params.max_range)

    def scan(self, pose: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Noisy ranges (N,) as the sensor reports them: metres, 0 for no return."""
        p = self.params
        ranges = self.true_ranges(pose)
        noisy = ranges + rng.normal(0.0, p.range_noise_std, size=ranges.shape) if p.range_noise_std else ranges
        dropped = rng.random(ranges.shape) < p.dropout if p.dropout else np.zeros(ranges.shape, dtype=bool)
        valid = np.isfinite(ranges) & (noisy >= p.min_range) & (noisy <= p.max_range) & ~dropped
        return np.where(valid, noisy, 0.0)
