"""The "virtual laser": N range beams cast from the robot against the maze's wall surfaces.

The exercise's robot measures ranges with an omnidirectional camera (Exercise 3's "virtual laser");
the simulator models it as an ideal ray caster plus Gaussian range noise and random dropouts. A
range of 0 means "no return" (out of range or dropped), as in the course log format.
"""

from __future__ import annotations

import enum
import math
from dataclasses import asdict, dataclass, field, fields

import numpy as np
from numpy.typing import ArrayLike

from mazeslam.core.beams import BeamGeometry
from mazeslam.core.config import require
from mazeslam.core.geometry import TWO_PI, transform_points
from mazeslam.core.limits import beams_problem
from mazeslam.sim.omnicam_sensor import OmnicamParams, OmnicamRanges

#: Angle (rad) by which a wall's angular extent is widened when choosing the beams to test.
ANGLE_MARGIN = 1e-9


class LaserModel(enum.StrEnum):
    """How true ranges become reported ones."""

    GAUSSIAN = "gaussian"  #: true range plus Gaussian noise of ``range_noise_std``
    OMNICAM = "omnicam"  #: the course robot's camera: edge noise and whole pixels (``mazeslam.sim.omnicam_sensor``)


@dataclass(frozen=True)
class LaserParams:
    """Virtual laser settings.

    Attributes:
        beams: number of beams over the field of view (the exercise's N; default 180, one per 2 deg).
        max_range: longest range reported, metres; farther walls give 0 (for the camera: the
            distance its mirror's outer radius sees).
        min_range: shortest range reported, metres; nearer walls give 0 (the camera's blind disc).
        model: ``"gaussian"`` (range plus ``range_noise_std``) or ``"omnicam"`` (the course robot's
            camera, ``omnicam``'s settings; ``range_noise_std`` is then unused).
        range_noise_std: standard deviation of the Gaussian range noise, metres.
        dropout: probability that a beam returns nothing (0), independent per beam.
        omnicam: the camera model's settings (TOML ``[laser.omnicam]``).
        geometry: where the beams point and where the sensor sits on the robot (TOML
            ``[laser.geometry]``; default: the exercise's convention, beam 0 behind, mounted on the
            wheel axle).
    """

    beams: int = 180
    max_range: float = 0.8
    min_range: float = 0.0
    model: LaserModel = LaserModel.GAUSSIAN
    range_noise_std: float = 0.003
    dropout: float = 0.0
    omnicam: OmnicamParams = field(default_factory=OmnicamParams)
    geometry: BeamGeometry = field(default_factory=BeamGeometry)

    def __post_init__(self):
        require(self.beams >= 1, f"laser beams must be at least 1, got {self.beams}")
        too_many = beams_problem(self.beams)
        require(too_many is None, f"laser beams: {too_many}")
        require(self.max_range > 0, f"laser max_range must be positive, got {self.max_range}")
        require(
            0 <= self.min_range < self.max_range, f"laser min_range must be in [0, max_range), got {self.min_range}"
        )
        require(self.range_noise_std >= 0, f"laser range_noise_std must be >= 0, got {self.range_noise_std}")
        require(0 <= self.dropout < 1, f"laser dropout must be in [0, 1), got {self.dropout}")
        require(self.model in tuple(LaserModel), f"laser model must be 'gaussian' or 'omnicam', got {self.model!r}")
        object.__setattr__(self, "model", LaserModel(self.model))

    def sensor_mapping(self) -> dict:
        """The map sidecar's ``sensor``: these settings with the geometry's fields beside them
        (flat: ``beams``, ``max_range``, ..., ``first_beam_angle``, ``direction``, ...), as
        ``mazeslam.data.sidecars.beam_geometry`` reads them; the camera model's settings as a table
        ``omnicam`` when that model is used."""
        settings = {f.name: getattr(self, f.name) for f in fields(self) if f.name not in ("geometry", "omnicam")}
        if self.model == LaserModel.OMNICAM:
            settings["omnicam"] = asdict(self.omnicam)
        return {**settings, **self.geometry.to_dict()}


class RayCaster:
    """Casts a fixed fan of beams against fixed wall segments, from any sensor pose.

    Everything that does not depend on the pose is computed once: the walls' bounding boxes, the
    beam directions and their angular order. Per cast, walls wholly farther than ``max_range`` are
    culled by their bounding boxes; then each remaining wall is intersected only with the beams
    inside the angle it subtends (binary search over the sorted beam bearings), so the work grows
    with the beams times the walls along each beam, not with beams times walls.

    Args:
        segments: (W, 4) walls ``[x1, y1, x2, y2]``, world metres.
        bearings: (N,) beam directions in the sensor frame, radians.
        max_range: metres; walls farther away are not seen.
    """

    def __init__(self, segments: ArrayLike, bearings: ArrayLike, max_range: float):
        segments = np.asarray(segments, dtype=float).reshape(-1, 4)
        self.start_x, self.start_y = segments[:, 0], segments[:, 1]
        self.vector_x, self.vector_y = segments[:, 2] - segments[:, 0], segments[:, 3] - segments[:, 1]
        self.box_low = np.minimum(segments[:, :2], segments[:, 2:])
        self.box_high = np.maximum(segments[:, :2], segments[:, 2:])
        self.max_range = float(max_range)
        self.bearings = np.asarray(bearings, dtype=float)
        self._cos, self._sin = np.cos(self.bearings), np.sin(self.bearings)
        positive = np.mod(self.bearings, TWO_PI)
        self._order = np.argsort(positive)
        self._sorted = np.concatenate([positive[self._order], positive[self._order] + TWO_PI])

    def cast(self, x: float, y: float, heading: float) -> np.ndarray:
        """Distances (N,) in metres from a sensor at (x, y) facing ``heading`` to the first wall
        along each beam; ``inf`` where no wall lies within ``max_range``."""
        beam, _, t, _ = self._crossings(x, y, heading)
        distances = np.full(len(self.bearings), np.inf)
        np.minimum.at(distances, beam, t)
        return distances

    def hits(
        self, x: float, y: float, heading: float, candidates: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """As ``cast``, with where each beam lands: ``(distances, walls, fractions)``, all (N,): the
        distances (m, inf: none within ``max_range``), the index of the wall segment hit (-1: none)
        and how far along it from its first end (0 to 1). ``candidates``: indices of the only walls
        a beam can meet first from here (e.g. ``walls.WallsInSight``), instead of every wall within
        ``max_range``."""
        beam, segment, t, s = self._crossings(x, y, heading, candidates)
        distances = np.full(len(self.bearings), np.inf)
        np.minimum.at(distances, beam, t)
        nearest = t == distances[beam]
        walls, fractions = np.full(len(self.bearings), -1), np.zeros(len(self.bearings))
        walls[beam[nearest]], fractions[beam[nearest]] = segment[nearest], s[nearest]
        return distances, walls, fractions

    def _crossings(self, x: float, y: float, heading: float, candidates: np.ndarray | None = None):
        """Every beam's crossings with the walls within ``max_range`` (or the ``candidates``): (M,)
        arrays of the beam index, the wall segment index, the distance (m) and the fraction along
        the segment."""
        if candidates is None:
            gap = np.maximum(np.maximum(self.box_low - (x, y), (x, y) - self.box_high), 0.0)
            near = np.flatnonzero(np.einsum("ij,ij->i", gap, gap) <= self.max_range**2)
        else:
            near = candidates
        px, py = self.start_x[near] - x, self.start_y[near] - y  # wall starts relative to the sensor
        ex, ey = self.vector_x[near], self.vector_y[near]
        segment, beam = self._beams_facing(px, py, px + ex, py + ey, heading)
        cos_h, sin_h = math.cos(heading), math.sin(heading)
        dx = (self._cos * cos_h - self._sin * sin_h)[beam]  # world beam directions, per pair
        dy = (self._sin * cos_h + self._cos * sin_h)[beam]
        px, py, ex, ey = px[segment], py[segment], ex[segment], ey[segment]
        # Solve t d = p + s e for each (beam, segment) pair with 2-D cross products.
        denom = dx * ey - dy * ex
        denom[denom == 0] = np.inf  # parallel: t = s = 0, never a hit
        t = (px * ey - py * ex) / denom
        s = (px * dy - py * dx) / denom
        hit = (t > 0) & (s >= 0) & (s <= 1) & (t <= self.max_range)
        return beam[hit], near[segment[hit]], t[hit], s[hit]

    def _beams_facing(self, x1, y1, x2, y2, heading: float):
        """Pairs ``(segment index, beam index)`` of every beam whose bearing lies within the angle a
        segment (endpoints relative to the sensor, world axes) subtends, widened by ``ANGLE_MARGIN``."""
        n = len(self.bearings)
        a = np.mod(np.arctan2(y1, x1) - heading, TWO_PI)  # endpoint bearings in the sensor frame
        b = np.mod(np.arctan2(y2, x2) - heading, TWO_PI)
        width = np.mod(b - a, TWO_PI)
        shorter_from_a = width <= np.pi  # a segment not through the sensor subtends less than pi
        low = np.where(shorter_from_a, a, b) - ANGLE_MARGIN
        high = low + np.where(shorter_from_a, width, TWO_PI - width) + 2 * ANGLE_MARGIN
        first = np.searchsorted(self._sorted, low)
        counts = np.minimum(np.searchsorted(self._sorted, high, side="right") - first, n)
        segment = np.repeat(np.arange(len(x1)), counts)
        position = np.arange(counts.sum()) + np.repeat(first - (np.cumsum(counts) - counts), counts)
        return segment, self._order[position % n]


def cast_rays(origin, angles, segments: np.ndarray, max_range: float) -> np.ndarray:
    """Distances (N,) from ``origin`` (2,) along world ``angles`` (N,) to the first of ``segments``
    (W, 4) hit, ``inf`` beyond ``max_range``: a one-off ``RayCaster`` cast."""
    return RayCaster(segments, angles, max_range).cast(float(origin[0]), float(origin[1]), 0.0)


class VirtualLaser:
    """Casts the configured beams from a robot pose and returns one noisy scan.

    The beam geometry (``params.geometry``) gives each beam's bearing in the robot frame and the
    sensor's mounting point; ``scan`` returns ranges in beam order, as written to a course log.
    The ``params.model`` turns true ranges into reported ones.
    """

    def __init__(self, params: LaserParams, surfaces: np.ndarray):
        self.params = params
        self.bearings = params.geometry.bearings(params.beams)  # (N,) robot frame, radians
        self.mount = (params.geometry.mount_x, params.geometry.mount_y)
        self.camera = OmnicamRanges(params.omnicam, self.bearings) if params.model == LaserModel.OMNICAM else None
        reach = self.camera.farthest_reported(params.max_range) if self.camera else params.max_range
        self.caster = RayCaster(surfaces, self.bearings, reach)

    def true_ranges(self, pose: np.ndarray) -> np.ndarray:
        """Noise-free ranges (N,) from robot ``pose`` (x, y, theta), ``inf`` beyond ``max_range`` (for
        the camera: beyond the farthest wall its noise can bring within ``max_range``)."""
        sensor_x, sensor_y = transform_points(pose, self.mount)
        return self.caster.cast(float(sensor_x), float(sensor_y), float(pose[2]))

    def scan(self, pose: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Noisy ranges (N,) as the sensor reports them: metres, 0 for no return."""
        return self.measure(self.true_ranges(pose), rng)

    def measure(self, ranges: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """What the sensor reports for the true ranges (N,): noise, dropouts, 0 outside its range."""
        p = self.params
        if self.camera is not None:
            noisy = self.camera.measure(ranges, rng)
        elif p.range_noise_std:
            noisy = ranges + rng.normal(0.0, p.range_noise_std, size=ranges.shape)
        else:
            noisy = ranges
        dropped = rng.random(ranges.shape) < p.dropout if p.dropout else np.zeros(ranges.shape, dtype=bool)
        valid = np.isfinite(ranges) & (noisy >= p.min_range) & (noisy <= p.max_range) & ~dropped
        return np.where(valid, noisy, 0.0)
