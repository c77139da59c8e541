"""Corner landmarks from a range scan: the exercise's ``extract_beacon`` and a stricter mode.

A scan's ranges become points in the sensor frame (the beam geometry says along which bearing each
range was measured); split-and-merge (``mazeslam.features.lines``) cuts them into straight segments;
each segment's end points are then classified by what lies beyond them in scan order:

=============  ===========================================================================  ======
kind           what it is                                                                   fixed?
=============  ===========================================================================  ======
``corner``     two neighbouring segments meet at a real angle: their lines' intersection    yes
``wall_end``   the scan jumps to a farther surface: the wall ends here (a convex corner     yes
               seen edge-on); placed where the line meets the ray between the two beams
``occluded``   the scan jumps to a nearer surface: something in front hides the wall        no
``gap``        the next beam has no return (or is outside the ranges used)                  no
``edge``       the end of a field of view narrower than a full circle                       no
``junction``   the next segment follows on without a real angle or a jump                   no
=============  ===========================================================================  ======

The exercise's mode (``mode="endpoints"``) reports every segment end point as an observation,
whatever its kind; ``mode="corners"`` reports only the fixed ones, ``corner`` and ``wall_end``:
points of the world that look the same from wherever the robot sees them.

Every observation is given in the robot frame (the sensor's mounting offset added) as x, y and as
range, bearing, each with a covariance propagated from the line fits.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, field

import numpy as np

from mazeslam.core.beams import BeamGeometry
from mazeslam.core.config import require
from mazeslam.features.lines import LineParams, LineSegment, SplitAndMerge

FIXED_KINDS = ("corner", "wall_end")


class CornerMode(enum.StrEnum):
    """Which segment ends become observations."""

    CORNERS = "corners"  #: the fixed kinds only (corners and wall ends)
    ENDPOINTS = "endpoints"  #: every segment end, as the exercise's extract_beacon


KINDS = (*FIXED_KINDS, "occluded", "gap", "edge", "junction")


@dataclass(frozen=True)
class CornerParams:
    """Corner extraction settings (lengths in metres, angles in degrees).

    Attributes:
        lines: split-and-merge settings.
        min_range, max_range: ranges used; others count as no return (the exercise trusts only
            part of its camera's range).
        max_abs_bearing: beams pointing farther than this from straight ahead (degrees, robot
            frame) count as no return (the exercise uses only the front half: 90).
        min_corner_angle: two neighbouring lines form a corner when they differ by at least this
            much (and at most 180 minus it).
        max_corner_gap: the intersection of two lines must lie within this distance (plus the gap
            between their facing end points) of both facing end points, or it is no corner.
        max_skipped_points: neighbouring segments of one run may form a corner across this many
            points that belong to neither (too few for a segment of their own).
        max_end_spacing: a wall end is reported only where neighbouring beams land at most this far
            apart on the wall; at grazing angles the end could lie anywhere in a wider stretch.
        end_face_std: extra standard deviation (m, in every direction) of a wall end: the end of a
            wall is a face as wide as the wall is thick, and seen from either side it ends at a
            different corner of that face (about half the wall thickness; 1 cm walls: 5 mm).
        mode: ``"corners"`` (fixed landmarks only) or ``"endpoints"`` (every segment end point, as
            the exercise's extract_beacon).
        covariance_scale: per kind, a factor on the covariance the line fits give (kinds not
            named: 1). ``mazeslam calibrate`` measures it: how wide the fits' covariance is against
            the observations' scatter, times (1 + rho) / (1 - rho) for the correlation rho of one
            landmark's errors from one scan to the next (a wall end's position along the wall
            depends on where the last beam lands, which changes slowly as the robot moves: its
            errors repeat, and the filter must not count them as new information each scan).
    """

    lines: LineParams = field(default_factory=LineParams)
    min_range: float = 0.02
    max_range: float = math.inf
    max_abs_bearing: float = 180.0
    min_corner_angle: float = 30.0
    max_corner_gap: float = 0.03
    max_skipped_points: int = 3
    max_end_spacing: float = 0.02
    end_face_std: float = 0.005
    mode: CornerMode = CornerMode.CORNERS
    covariance_scale: dict[str, float] = field(default_factory=lambda: {"corner": 0.84, "wall_end": 5.5})

    def __post_init__(self):
        require(
            0 <= self.min_range < self.max_range,
            f"corner min_range {self.min_range} must be >= 0 and below max_range {self.max_range}",
        )
        require(
            0 < self.max_abs_bearing <= 180, f"max_abs_bearing must be in (0, 180] degrees, got {self.max_abs_bearing}"
        )
        require(
            0 < self.min_corner_angle <= 90, f"min_corner_angle must be in (0, 90] degrees, got {self.min_corner_angle}"
        )
        require(self.max_corner_gap > 0, f"max_corner_gap must be positive, got {self.max_corner_gap}")
        require(self.max_skipped_points >= 0, f"max_skipped_points must be >= 0, got {self.max_skipped_points}")
        require(self.max_end_spacing > 0, f"max_end_spacing must be positive, got {self.max_end_spacing}")
        require(self.end_face_std >= 0, f"end_face_std must be >= 0, got {self.end_face_std}")
        require(self.mode in tuple(CornerMode), f"mode must be 'corners' or 'endpoints', got {self.mode!r}")
        object.__setattr__(self, "mode", CornerMode(self.mode))
        require(
            isinstance(self.covariance_scale, dict) and set(self.covariance_scale) <= set(KINDS),
            f"covariance_scale names kinds among {', '.join(KINDS)}, got {self.covariance_scale!r}",
        )
        require(
            all(isinstance(value, (int, float)) and 0 < value < math.inf for value in self.covariance_scale.values()),
            f"covariance_scale factors must be positive numbers, got {self.covariance_scale!r}",
        )


@dataclass(slots=True)
class CornerObservation:
    """One landmark observation in the robot frame.

    Attributes:
        x, y: position, metres (robot frame: x forward, y left).
        range, bearing: the same as range (m) and bearing (rad, counter-clockwise from forward).
        kind: see the module's table.
        covariance_xy: (2, 2) covariance of (x, y), m^2.
        covariance_rb: (2, 2) covariance of (range, bearing).
        beam: index of the beam nearest to it.
        facing: the direction the landmark faces, towards the side it is seen from (rad, robot
            frame): a corner's bisector of its two walls' normals, a segment end's wall normal.
            Two landmarks a wall's thickness apart (the two face corners of a wall end; the
            corners either side of a thin wall) face far apart ways: it tells them apart.
    """

    x: float
    y: float
    range: float
    bearing: float
    kind: str
    covariance_xy: np.ndarray
    covariance_rb: np.ndarray
    beam: int
    facing: float

    @property
    def fixed(self) -> bool:
        return self.kind in FIXED_KINDS


@dataclass
class ScanFeatures:
    """What one scan yields: its points, lines and observations (sensor-frame geometry, robot-frame landmarks).

    Attributes:
        points: (P, 2) the valid scan points in scan order, sensor frame, metres.
        beams: (P,) the beam index of each point.
        segments: the extracted lines, in scan order (positions index ``points``).
        observations: corners and/or end points, robot frame.
    """

    points: np.ndarray
    beams: np.ndarray
    segments: list[LineSegment]
    observations: list[CornerObservation]

    def observation_array(self) -> np.ndarray:
        """(K, 2) observation ranges and bearings, the filter's input."""
        return np.array([[o.range, o.bearing] for o in self.observations]).reshape(-1, 2)

    def observation_facings(self) -> np.ndarray:
        """(K,) the observations' facing directions (rad, robot frame)."""
        return np.array([o.facing for o in self.observations], dtype=float)

    def observation_covariances(self) -> np.ndarray:
        """(K, 2, 2) the observations' range/bearing covariances."""
        return np.array([o.covariance_rb for o in self.observations]).reshape(-1, 2, 2)


class CornerExtractor:
    """Extracts lines and corner observations from scans of a fixed beam geometry.

    ``extract(ranges)`` takes one scan (N,) in metres (0 = no return) and returns ``ScanFeatures``.
    """

    def __init__(self, geometry: BeamGeometry, n_beams: int, params: CornerParams | None = None):
        self.geometry = geometry
        self.params = params or CornerParams()
        self.n_beams = n_beams
        self.step = geometry.angle_step(n_beams)
        self.bearings = geometry.bearings(n_beams)
        self._cos, self._sin = np.cos(self.bearings), np.sin(self.bearings)
        self._indices = np.arange(n_beams)
        self._bearing_used = np.abs(self.bearings) <= math.radians(self.params.max_abs_bearing) + 1e-12
        self._splitter = SplitAndMerge(self.params.lines)
        lam = math.radians(self.params.lines.breakpoint_angle)
        self._breakpoint_gain = math.sin(self.step) / math.sin(max(lam - self.step, 1e-6))
        self._mount_x, self._mount_y = geometry.mount_x, geometry.mount_y
        lines = self.params.lines
        self._on_line = lines.split_threshold + 3 * lines.range_noise_std  # a point this near a line is on it

    def extract(self, ranges) -> ScanFeatures:
        ranges = np.asarray(ranges, dtype=float)
        if ranges.shape != (self.n_beams,):
            raise ValueError(f"expected a scan of {self.n_beams} ranges, got shape {ranges.shape}")
        p = self.params
        valid = (ranges >= p.min_range) & (ranges <= p.max_range) & (ranges > 0) & self._bearing_used
        breaks = self._breaks(ranges, valid)
        closed = not breaks.any()
        # Scan order starts just after a break, so that no run wraps around the end. A closed loop
        # (a room seen all round) is cut where a first pass finds two segments meeting.
        start = int(np.argmax(breaks)) + 1 if not closed else int(np.argmin(ranges))
        beams, points, runs, segments = self._segments(ranges, valid, breaks, start)
        if closed and len(segments) > 1:
            beams, points, runs, segments = self._segments(ranges, valid, breaks, int(beams[segments[1].first]))
        observations = self._observations(ranges, valid, breaks, beams, segments, runs, closed)
        return ScanFeatures(points, beams, segments, observations)

    def _segments(self, ranges, valid, breaks, start: int):
        """Split-and-merge in scan order from beam ``start``: (beams (P,), points (P, 2), runs, segments)."""
        order = (self._indices + start) % self.n_beams
        beams = order[valid[order]]
        points = np.column_stack([ranges[beams] * self._cos[beams], ranges[beams] * self._sin[beams]])
        cut = np.flatnonzero(breaks[beams[:-1]]) + 1  # positions that start a new run
        runs = list(zip(np.concatenate([[0], cut]).tolist(), np.concatenate([cut - 1, [len(beams) - 1]]).tolist()))
        return beams, points, runs, self._splitter.segment(points, runs) if len(beams) else []

    def _breaks(self, ranges: np.ndarray, valid: np.ndarray) -> np.ndarray:
        """(N,) True where beam k and the next beam in scan order do not lie on one surface: either
        has no return, or their points are farther apart than the adaptive breakpoint distance
        ``r sin(step) / sin(lambda - step) + 3 sigma``. The last beam of a fan always breaks."""
        following = np.roll(self._indices, -1)
        x, y = ranges * self._cos, ranges * self._sin
        spacing = np.hypot(x[following] - x, y[following] - y)
        allowed = ranges * self._breakpoint_gain + 3 * self.params.lines.range_noise_std
        breaks = ~valid | ~valid[following] | (spacing > allowed)
        if not self.geometry.is_full_circle:
            breaks[-1] = True
        return breaks

    def _observations(self, ranges, valid, breaks, beams, segments, runs, closed) -> list[CornerObservation]:
        run_of = np.zeros(len(beams), dtype=int)
        for index, (first, last) in enumerate(runs):
            run_of[first : last + 1] = index
        pairs = [
            (
                i,
                i + 1,
                segments[i + 1].first - segments[i].last - 1,
                run_of[segments[i].last] == run_of[segments[i + 1].first],
            )
            for i in range(len(segments) - 1)
        ]
        if closed and len(segments) > 1:  # the loop closes: the last segment meets the first
            pairs.append((len(segments) - 1, 0, len(beams) - 1 - segments[-1].last + segments[0].first, True))
        observations = []
        corner_after, corner_before = [False] * len(segments), [False] * len(segments)
        for i, j, skipped, same_run in pairs:
            if same_run and skipped <= self.params.max_skipped_points:
                corner = self._corner(segments[i], segments[j])
                if corner is not None:
                    corner_after[i] = corner_before[j] = True
                    if self.params.mode == CornerMode.CORNERS:
                        point, covariance = corner
                        facing = _toward_sensor(segments[i].normal + segments[j].normal)
                        observations.append(
                            self._observation(point, np.array(covariance), "corner", beams[segments[i].last], facing)
                        )
        for i, segment in enumerate(segments):
            for at_start in (True, False):
                position = segment.first if at_start else segment.last
                has_corner = corner_before[i] if at_start else corner_after[i]
                kind = (
                    "corner"
                    if has_corner
                    else self._end_kind(ranges, valid, breaks, beams[position], at_start, segment)
                )
                facing = _toward_sensor(segment.normal)
                if self.params.mode == CornerMode.ENDPOINTS:
                    point = segment.start if at_start else segment.end
                    observations.append(
                        self._observation(point, self._end_covariance(segment, point), kind, beams[position], facing)
                    )
                elif kind == "wall_end":
                    end = self._wall_end(segment, beams[position], at_start)
                    if end is not None:
                        observations.append(self._observation(*end, kind, beams[position], facing))
        return observations

    def _end_kind(self, ranges, valid, breaks, beam: int, at_start: bool, segment: LineSegment) -> str:
        """Classify a segment end point by the beams just beyond it in scan order.

        Across a break, a farther surface makes the end a wall end, a nearer one an occlusion; but a
        point beyond the break that lies on the segment's own line means the same wall goes on
        (sparse beams at a grazing angle): no landmark. One point right beyond the end that belongs
        to no segment (the thin end face of a wall) may precede the break: up to
        ``max_skipped_points`` of them, within ``max_corner_gap`` of the end.
        """
        step = -1 if at_start else 1
        previous = beam
        end_point = self._point(ranges, beam)
        for hop in range(1, self.params.max_skipped_points + 2):
            neighbour = beam + step * hop
            if not self.geometry.is_full_circle and not 0 <= neighbour < self.n_beams:
                return "edge"
            neighbour %= self.n_beams
            if not valid[neighbour]:
                return "gap"
            if breaks[previous if step > 0 else neighbour]:
                point = self._point(ranges, neighbour)
                if abs(point @ segment.normal - segment.r) <= self._on_line:
                    return "junction"
                return "wall_end" if ranges[neighbour] > ranges[previous] else "occluded"
            if math.dist(self._point(ranges, neighbour), end_point) > self.params.max_corner_gap:
                break
            previous = neighbour
        return "junction"

    def _point(self, ranges, beam: int) -> np.ndarray:
        return ranges[beam] * np.array([self._cos[beam], self._sin[beam]])

    def _corner(self, a: LineSegment, b: LineSegment):
        """Intersection (2,) and its covariance of two neighbouring segments meeting at a real angle, or None."""
        difference = abs(math.remainder(a.alpha - b.alpha, math.pi))  # lines: alpha modulo pi
        if difference < math.radians(self.params.min_corner_angle):
            return None
        # Solve [n_a; n_b] p = [r_a; r_b] (Cramer's rule).
        (ca, sa), (cb, sb) = (math.cos(a.alpha), math.sin(a.alpha)), (math.cos(b.alpha), math.sin(b.alpha))
        determinant = ca * sb - sa * cb
        x, y = (a.r * sb - b.r * sa) / determinant, (ca * b.r - cb * a.r) / determinant
        gap = self.params.max_corner_gap + math.dist(a.end, b.start)  # the beams may straddle the corner
        if math.dist((x, y), a.end) > gap or math.dist((x, y), b.start) > gap:
            return None
        # Each line contributes a residual dr - (t . p) dalpha, t = (-sin, cos); the two are independent.
        va = _line_offset_variance(a.covariance, -sa * x + ca * y)
        vb = _line_offset_variance(b.covariance, -sb * x + cb * y)
        inverse = (sb / determinant, -sa / determinant, -cb / determinant, ca / determinant)
        return (x, y), _sandwich(inverse, ((va, 0.0), (0.0, vb)))

    def _wall_end(
        self, segment: LineSegment, beam: int, at_start: bool
    ) -> tuple[tuple[float, float], np.ndarray] | None:
        """Where a wall ends between its last beam and the next: the line meets the ray halfway.

        Returns ``(point, covariance (2, 2))``, or None when the two beams land farther apart on the
        line than ``max_end_spacing`` (a wall seen at a grazing angle: its end is too vague).
        """
        direction = self.geometry.direction * (-1 if at_start else 1)
        bearing = float(self.bearings[beam]) + direction * 0.5 * self.step
        ray_x, ray_y = math.cos(bearing), math.sin(bearing)
        c, s = math.cos(segment.alpha), math.sin(segment.alpha)
        along_normal = ray_x * c + ray_y * s  # cosine of the angle of incidence (signed)
        if abs(along_normal) < 1e-6 or segment.r / along_normal <= 0:
            return None
        distance = segment.r / along_normal
        stretch = distance * self.step / abs(along_normal)  # how far apart two beams land on the line here
        if stretch > self.params.max_end_spacing:
            return None
        point = (distance * ray_x, distance * ray_y)
        # The wall ends somewhere between the two beams (uniform over that stretch of the line),
        # at one corner or the other of its end face.
        face = self.params.end_face_std**2 * np.eye(2)
        return point, self._end_covariance(segment, point, along_var=stretch**2 / 12) + face

    def _end_covariance(self, segment: LineSegment, point, along_var: float | None = None) -> np.ndarray:
        """Covariance (2, 2) of a point on a segment's line: the fit's offset across it, and along it
        ``along_var`` (default: a quarter of the beam spacing there, squared)."""
        c, s = math.cos(segment.alpha), math.sin(segment.alpha)
        x, y = point
        across = _line_offset_variance(segment.covariance, -s * x + c * y)
        if along_var is None:
            distance = max(math.hypot(x, y), 1e-9)
            facing = max(abs(c * x + s * y) / distance, 0.1)
            along_var = (0.25 * distance * self.step / facing) ** 2
        # across n n^T + along t t^T with n = (c, s), t = (-s, c)
        return np.array(
            [
                [across * c * c + along_var * s * s, (across - along_var) * c * s],
                [(across - along_var) * c * s, across * s * s + along_var * c * c],
            ]
        )

    def _observation(self, point_sensor, covariance_xy, kind: str, beam: int, facing: float) -> CornerObservation:
        x, y = float(point_sensor[0]) + self._mount_x, float(point_sensor[1]) + self._mount_y
        rng2 = x * x + y * y
        rng = math.sqrt(rng2)
        jacobian = (x / rng, y / rng, -y / rng2, x / rng2)  # d(range, bearing)/d(x, y)
        covariance_xy = np.asarray(covariance_xy) * self.params.covariance_scale.get(kind, 1.0)
        return CornerObservation(
            x,
            y,
            rng,
            math.atan2(y, x),
            kind,
            covariance_xy,
            np.array(_sandwich(jacobian, covariance_xy.tolist())),
            int(beam),
            facing,
        )


def _toward_sensor(normal: np.ndarray) -> float:
    """The angle (rad) of ``-normal``: a line's normal (cos alpha, sin alpha) points away from the
    sensor (r >= 0), so its opposite is the way the wall faces."""
    return math.atan2(-normal[1], -normal[0])


def _line_offset_variance(covariance: np.ndarray, along: float) -> float:
    """Variance of a line's offset dr - along * dalpha at along-line coordinate ``along``."""
    (vr, c), (_, va) = covariance.tolist()
    return vr - 2 * along * c + along * along * va


def _sandwich(j, covariance) -> tuple[tuple[float, float], tuple[float, float]]:
    """J C J^T for J = ((j0, j1), (j2, j3)) given as (j0, j1, j2, j3) and C a 2x2 nested sequence."""
    j0, j1, j2, j3 = j
    (c00, c01), (c10, c11) = covariance
    a00, a01 = j0 * c00 + j1 * c10, j0 * c01 + j1 * c11
    a10, a11 = j2 * c00 + j3 * c10, j2 * c01 + j3 * c11
    cross = a00 * j2 + a01 * j3
    return ((a00 * j0 + a01 * j1, cross), (cross, a10 * j2 + a11 * j3))
