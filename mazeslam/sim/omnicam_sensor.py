"""The course robot's range sensor: an omnidirectional camera read as a "virtual laser".

The camera sees the floor in a curved mirror; a wall's foot at floor distance d appears at pixel
radius rho = alpha atan(d / h) (the exercise's mirror model, ``mazeslam.core.mirror``). The range
is read back from the first dark pixel outward, so what the sensor reports is

    rho' = whole pixel containing (rho + edge noise), taken at its centre
    d'   = h tan(rho' / alpha)

with Gaussian edge noise in pixels (blur, lighting, a wall's uneven edge); beams in sectors the
mirror's supports hide report nothing. A pixel covers dd/drho = h / alpha sec^2(rho / alpha) metres
of floor, which grows with distance: about 2 mm at 0.1 m, 4 mm at 0.2 m and 8 mm at 0.3 m for the
exercise's mirror (h 0.126 m, alpha 107 px/rad), so the range error grows with distance as the real
sensor's does. The mirror's constants are those of ``CameraCalibration``; the ring's radii are the
laser's ``min_range`` and ``max_range`` (metres), which ``VirtualLaser`` applies to the reported
ranges.

Not modelled (experiments/course_robot/sensor_comparison.md): log1's walls also bend by a few
millimetres over many neighbouring beams, and its edge noise grows towards the ring's inner edge;
here the walls are straight and one edge noise, independent from beam to beam, holds at all ranges.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mazeslam.core.config import require
from mazeslam.core.mirror import CameraCalibration


@dataclass(frozen=True)
class OmnicamParams:
    """The camera's range-model settings (TOML ``[laser.omnicam]``), used when ``[laser] model = "omnicam"``.

    Attributes:
        edge_noise_px: standard deviation of the wall edge's pixel radius, pixels (Gaussian,
            independent per beam and scan). Default: log1's, measured on its first 8 scans, taken
            standing still (their whole-pixel ranges vary by 0.20 px^2 per beam, as a 0.35 px
            Gaussian's do after rounding to whole pixels).
        pixel_step: radial sampling of the image, pixels: the edge is found to the whole pixel
            (1.0); 0 reports the noisy radius unquantised.
        occluded: bearing sectors ``[from, to]`` (degrees, robot frame, counter-clockwise from
            forward, inclusive, 0-360) in which the camera never sees the floor (the mirror's
            supports, cables): their beams always report 0.
    """

    edge_noise_px: float = 0.35
    pixel_step: float = 1.0
    occluded: tuple[tuple[float, float], ...] = ()

    def __post_init__(self):
        require(
            0 <= self.edge_noise_px <= 100, f"omnicam edge_noise_px must be in [0, 100] px, got {self.edge_noise_px}"
        )
        require(0 <= self.pixel_step <= 100, f"omnicam pixel_step must be in [0, 100] px, got {self.pixel_step}")
        require(
            all(0 <= low <= 360 and 0 <= high <= 360 for low, high in self.occluded),
            f"omnicam occluded sectors must be [from, to] pairs of degrees in 0-360, got {self.occluded!r}",
        )
        object.__setattr__(self, "occluded", tuple((float(low), float(high)) for low, high in self.occluded))


class OmnicamRanges:
    """True floor distances turned into the ranges the camera reports (before the laser's range limits).

    Args:
        params: the noise, sampling and occlusion settings.
        bearings: (N,) the beams' bearings in the robot frame, radians.
    """

    def __init__(self, params: OmnicamParams, bearings: np.ndarray):
        self.params = params
        #: The exercise's mirror (default height and alpha); the ring's centre and radii are unused here.
        self.mirror = CameraCalibration(center_x=0.0, center_y=0.0, inner_radius=0.0, outer_radius=1.0)
        self.horizon = self.mirror.alpha * math.pi / 2  # pixel radius of the horizon (d = infinity)
        self.occluded = occluded_beams(np.asarray(bearings, dtype=float), params.occluded)  # (N,) bool

    def farthest_reported(self, max_range: float) -> float:
        """The farthest true range (m) whose edge noise (up to 6 sigma) and pixel can bring it
        within ``max_range`` (m); ``inf`` when that reaches the horizon. A ray caster must reach this far."""
        p = self.params
        rho = float(self.mirror.radius(np.asarray(max_range))) + 6 * p.edge_noise_px + p.pixel_step
        return float(self.mirror.distance(np.asarray(rho))) if rho < self.horizon else math.inf

    def measure(self, ranges: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Reported ranges (N,) in metres for the beams' true floor distances ``ranges`` (N,) in
        metres: ``inf`` where the true range is ``inf`` (no wall), the beam is occluded or the
        noisy edge lies at or beyond the horizon."""
        p = self.params
        ranges = np.asarray(ranges, dtype=float)
        rho = self.mirror.radius(np.where(np.isfinite(ranges), ranges, 0.0))
        if p.edge_noise_px:
            rho = rho + rng.normal(0.0, p.edge_noise_px, size=rho.shape)
        if p.pixel_step:
            rho = (np.floor(rho / p.pixel_step) + 0.5) * p.pixel_step
        seen = np.isfinite(ranges) & ~self.occluded & (rho >= 0) & (rho < self.horizon)
        return np.where(seen, self.mirror.distance(np.where(seen, rho, 0.0)), np.inf)


def occluded_beams(bearings: np.ndarray, sectors) -> np.ndarray:
    """(N,) True for the beams whose bearing (N,) radians lies in one of ``sectors``: ``[from, to]``
    degrees, 0-360 counter-clockwise, inclusive; a sector with from > to wraps through 0."""
    degrees = np.mod(np.degrees(bearings), 360.0)
    tolerance = 1e-6  # a beam exactly on a sector's edge counts as inside
    occluded = np.zeros(len(degrees), dtype=bool)
    for low, high in sectors:
        above, below = degrees >= low - tolerance, degrees <= high + tolerance
        occluded |= (above & below) if low <= high else (above | below)
    return occluded
