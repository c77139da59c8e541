"""Find a log's beam convention from its own data: which first-beam angle and direction make
consecutive scans agree once moved by the odometry between them.

For two scans a and b and the sensor's motion (dtheta, t) between them (dead reckoning, with the
sensor's mounting offset), a candidate convention (first-beam angle phi0, direction d) puts b's
points into a's frame; the score is how far they land from a's points (the median distance from
each of b's points to the nearest of a's: robust to what one scan sees and the other does not).
Because a change of phi0 rotates both scans alike, with q the points for phi0 = 0,

    | R(dtheta) R(phi0) q_b + t - R(phi0) q_a | = | R(dtheta) q_b - q_a + R(-phi0) t |,

so one k-d tree per scan pair and direction serves every phi0: only the translation turns. Pure
rotations cannot tell phi0 apart (only the direction), so the pairs with the most translation
are used. The score of a candidate is the mean over the pairs, in metres.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from mazeslam.core.beams import BeamGeometry, SensorOverrides
from mazeslam.core.geometry import advance_pose, compose, relative, wrap_angle
from mazeslam.core.outputs import write_file
from mazeslam.data import log
from mazeslam.data.loaded_run import LoadedRun, load_run

if TYPE_CHECKING:
    from mazeslam.pipeline import SlamConfig


@dataclass(frozen=True)
class ConventionScore:
    """A candidate convention and its score (mean median residual, metres; lower is better)."""

    first_beam_angle: float
    direction: int
    score: float


@dataclass(frozen=True)
class Detection:
    """The best convention, the runner-up that is a different convention (the other direction or
    more than ``separation`` degrees away), and every candidate's score."""

    best: ConventionScore
    runner_up: ConventionScore
    candidates: list[ConventionScore]
    pairs: int

    @property
    def margin(self) -> float:
        """How many times the runner-up's score the best's is below it (>= 1)."""
        return self.runner_up.score / max(self.best.score, 1e-12)

    def score_of(self, geometry: BeamGeometry) -> float:
        """The score of the candidate nearest to ``geometry``'s convention."""
        same = [c for c in self.candidates if c.direction == geometry.direction]
        return min(same, key=lambda c: abs(wrap_angle(c.first_beam_angle - geometry.first_beam_angle))).score


def detect_beam_convention(
    course_log: log.CourseLog,
    mount_x: float = 0.0,
    min_range: float = 0.0,
    max_range: float = math.inf,
    jump_tolerance: float = math.inf,
    step_degrees: float = 1.0,
    max_pairs: int = 40,
    separation: float = 20.0,
    coarse_degrees: float = 5.0,
    refined: int = 2,
    max_points: int = 100,
    directions: tuple[int, ...] = (1, -1),
) -> Detection:
    """Score first-beam angles over the full circle, both directions: every ``coarse_degrees``,
    then every ``step_degrees`` within one coarse step of the ``refined`` best coarse angles of
    each direction (the score changes smoothly with the angle: the shift ``R(-phi0) t`` turns).
    Of each pair's second scan at most ``max_points`` evenly spaced points are matched (the
    median distance needs no more). ``directions``: the beam directions to try (one when known)."""
    if course_log.n_beams is None:
        raise ValueError(f"{course_log.source}: no scans to detect a beam convention from")
    # Full-circle scans (the course logs); a front fan's angles are known from its format.
    n = course_log.width
    pairs = _scan_pairs(course_log, mount_x, jump_tolerance, max_pairs)
    if not pairs:
        raise ValueError(f"{course_log.source}: the robot never moves between two scans; nothing to detect from")
    coarse = np.radians(np.arange(0.0, 360.0, coarse_degrees))
    candidates = []
    for direction in directions:
        bearings = BeamGeometry(first_beam_angle=0.0, direction=direction).bearings(n)  # q: phi0 = 0
        matched = [
            _matched_pair(course_log, a, b, motion, bearings, min_range, max_range, max_points)
            for (a, b), motion in pairs
        ]
        matched = [pair for pair in matched if pair is not None]
        scores = _scores(matched, coarse, len(pairs))
        fine = np.concatenate(
            [
                coarse[best] + np.radians(np.arange(-coarse_degrees, coarse_degrees + step_degrees / 2, step_degrees))
                for best in np.argsort(scores)[:refined]
            ]
        )
        angles, scores = np.r_[coarse, fine], np.r_[scores, _scores(matched, fine, len(pairs))]
        candidates += [ConventionScore(float(wrap_angle(a)), direction, float(s)) for a, s in zip(angles, scores)]
    ranked = sorted(candidates, key=lambda c: c.score)
    best = ranked[0]
    runner_up = next(
        c
        for c in ranked[1:]
        if c.direction != best.direction
        or abs(wrap_angle(c.first_beam_angle - best.first_beam_angle)) > math.radians(separation)
    )
    return Detection(best, runner_up, candidates, len(pairs))


def _matched_pair(course_log, a: int, b: int, motion, bearings, min_range: float, max_range: float, max_points: int):
    """Scan ``a``'s points in a k-d tree and at most ``max_points`` of scan ``b``'s, rotated by the
    motion's turn (both for phi0 = 0), with the motion's translation (2,); None when either scan
    has under 3 points."""
    q_a = _points(course_log.values[a], bearings, min_range, max_range)
    q_b = _points(course_log.values[b], bearings, min_range, max_range)
    q_b = q_b[:: -(-len(q_b) // max_points)] if len(q_b) else q_b
    if len(q_a) < 3 or len(q_b) < 3:
        return None
    dtheta = motion[2]
    moved = q_b @ np.array([[math.cos(dtheta), math.sin(dtheta)], [-math.sin(dtheta), math.cos(dtheta)]])
    from scipy.spatial import cKDTree  # here: scipy.spatial is slow to load, and a cached detection skips it

    return cKDTree(q_a), moved, np.asarray(motion[:2])


def _scores(matched: list, angles: np.ndarray, pairs: int) -> np.ndarray:
    """The mean over ``pairs`` scan pairs of the median distance (m) from b's points to a's, for
    each first-beam angle of ``angles`` (A,) rad: R(-phi0) t shifts b's points (see the module)."""
    totals = np.zeros(len(angles))
    cos_p, sin_p = np.cos(angles), np.sin(angles)
    for tree, moved, (tx, ty) in matched:
        shifts = np.column_stack([cos_p * tx + sin_p * ty, -sin_p * tx + cos_p * ty])  # (A, 2)
        queries = moved[None, :, :] + shifts[:, None, :]  # (A, Q, 2)
        distances, _ = tree.query(queries.reshape(-1, 2))
        totals += np.median(distances.reshape(len(angles), -1), axis=1)
    return totals / pairs


def _points(ranges: np.ndarray, bearings: np.ndarray, min_range: float, max_range: float) -> np.ndarray:
    valid = (ranges > 0) & (ranges >= min_range) & (ranges <= max_range)
    return np.column_stack([ranges[valid] * np.cos(bearings[valid]), ranges[valid] * np.sin(bearings[valid])])


def _scan_pairs(
    course_log: log.CourseLog,
    mount_x: float,
    jump_tolerance: float,
    max_pairs: int,
    window: int = 12,
    shortest: float = 0.02,
    longest: float = 0.25,
    most_turn: float = 1.0,
):
    """Pairs of nearby scans ((record a, record b), sensor motion (dx, dy, dtheta) in a's frame):
    b among the ``window`` scans after a, the sensor moved between ``shortest`` and ``longest``
    metres (enough to tell conventions apart, little enough to see the same walls); the longest
    moves first, at most ``max_pairs``, each scan in at most two pairs. Pairs turning more than
    ``most_turn`` rad come only after all others: odometry is least right in turns (wheels slip,
    a sensor ahead of the axle swings), and a turn tells the conventions apart least."""
    pose = np.zeros(3)
    scan_poses = {}
    for record in course_log.records():
        if isinstance(record, log.OdometryRecord) and abs(record.distance) <= jump_tolerance:
            pose = advance_pose(pose, record.distance, record.turn)
        elif isinstance(record, log.ScanRecord):
            scan_poses[record.index] = compose(pose, [mount_x, 0.0, 0.0])
    indices = sorted(scan_poses)
    pairs = []
    for i, a in enumerate(indices):
        for b in indices[i + 1 : i + 1 + window]:
            motion = relative(scan_poses[a], scan_poses[b])
            if shortest <= math.hypot(motion[0], motion[1]) <= longest:
                pairs.append(((a, b), motion))
    pairs.sort(key=lambda p: (abs(p[1][2]) > most_turn, -math.hypot(p[1][0], p[1][1])))
    chosen = []
    uses: dict[int, int] = {}
    for (a, b), motion in pairs:
        if uses.get(a, 0) < 2 and uses.get(b, 0) < 2:
            chosen.append(((a, b), motion))
            uses[a], uses[b] = uses.get(a, 0) + 1, uses.get(b, 0) + 1
        if len(chosen) == max_pairs:
            break
    return chosen


def convention_warning(
    course_log: log.CourseLog,
    geometry: BeamGeometry,
    min_range: float = 0.0,
    max_range: float = math.inf,
    jump_tolerance: float = math.inf,
    clearly_worse: float = 1.5,
) -> str | None:
    """A warning naming the better convention when ``geometry``'s scores ``clearly_worse`` times
    the best one's, else None."""
    detection = detect_beam_convention(course_log, geometry.mount_x, min_range, max_range, jump_tolerance)
    ratio = detection.score_of(geometry) / max(detection.best.score, 1e-12)
    if ratio < clearly_worse:
        return None
    best = detection.best
    return (
        f"warning: with beam 0 at {math.degrees(geometry.first_beam_angle):.0f} deg, direction "
        f"{geometry.direction:+d}, consecutive scans agree {ratio:.1f} times worse than with beam 0 at "
        f"{math.degrees(best.first_beam_angle):.0f} deg, direction {best.direction:+d}: try "
        f"--first-beam-angle {best.first_beam_angle:.4f} --beam-direction {best.direction}"
    )


def describe(detection: Detection) -> list[str]:
    """Lines that report a detection."""
    best, runner_up = detection.best, detection.runner_up
    return [
        f"beam convention detected from {detection.pairs} pairs of scans "
        "(median distance between matched points; lower is better):",
        f"  best        beam 0 at {math.degrees(best.first_beam_angle):+7.1f} deg ({best.first_beam_angle:+.4f} rad), "
        f"direction {best.direction:+d}: {1000 * best.score:.2f} mm",
        f"  runner-up   beam 0 at {math.degrees(runner_up.first_beam_angle):+7.1f} deg, "
        f"direction {runner_up.direction:+d}: "
        f"{1000 * runner_up.score:.2f} mm (margin x{detection.margin:.2f})",
    ]


#: The file in a command's output folder that keeps the beam convention detected for its log.
CACHE_NAME = "beam_convention.json"
#: Changes with the detection's method, so that a cache of an older method is not read.
DETECTION_VERSION = 2
#: A detected first-beam angle within this many degrees of a quarter turn is taken as that turn:
#: loggers put beam 0 forward, behind or sideways, and the detection's grid and noise are ~1 deg.
SNAP_DEGREES = 3.0
#: Below this margin (runner-up's score over the best's) the detection is inconclusive.
CONCLUSIVE_MARGIN = 1.2


def convention_given(sensor: SensorOverrides) -> bool:
    """The settings (config or command line) give the beam convention: first-beam angle or direction."""
    return sensor.first_beam_angle is not None or sensor.direction is not None


def loaded_with_convention(path: str | Path, config: SlamConfig, cache_folder: Path | None = None) -> LoadedRun:
    """The log at ``path`` loaded with ``config``'s ``[sensor]`` (``load_run``) and its beam convention
    detected where nothing says it (``with_detected_convention``): how the commands load a log."""
    return with_detected_convention(load_run(path, config.sensor), config, cache_folder)


def with_detected_convention(run: LoadedRun, config: SlamConfig, cache_folder: Path | None = None) -> LoadedRun:
    """``run`` with its beam convention detected from its scans (``detected_geometry`` with
    ``config``'s corner ranges and jump tolerance, cached as ``CACHE_NAME`` in ``cache_folder``) when
    nothing says it: a full-circle log with no sidecar and no first-beam angle in ``config.sensor``
    (a direction given alone is kept, and only the angle detected). Otherwise ``run`` as it is."""
    full_circle = run.geometry.is_full_circle and run.log.n_beams is not None and run.log.is_scan.sum() > 1
    if not full_circle or run.geometry_from_sidecar or config.sensor.first_beam_angle is not None:
        return run
    cache = Path(cache_folder) / CACHE_NAME if cache_folder is not None else None
    corners, jump_tolerance = config.corners, config.odometry.jump_tolerance
    geometry, origin = detected_geometry(
        run, corners.min_range, corners.max_range, jump_tolerance, cache, direction=config.sensor.direction
    )
    return dataclasses.replace(run, geometry=geometry, geometry_origin=origin)


def detected_geometry(
    run: LoadedRun,
    min_range: float = 0.0,
    max_range: float = math.inf,
    jump_tolerance: float = math.inf,
    cache: Path | None = None,
    direction: int | None = None,
) -> tuple[BeamGeometry, str]:
    """``run``'s beam geometry with the convention detected from its scans, and a line saying so.

    The mounting offset stays ``run``'s. An inconclusive detection (margin under
    ``CONCLUSIVE_MARGIN``, or a robot that never moves) keeps ``run``'s geometry. ``cache``: a JSON
    file that keeps the detection for this log's bytes and these settings, so that a rerun skips it.
    ``direction``: the beam direction when known (only the first-beam angle is then detected)."""
    settings = {
        name: value if math.isfinite(value) else None
        for name, value in (
            ("mount_x", run.geometry.mount_x),
            ("min_range", min_range),
            ("max_range", max_range),
            ("jump_tolerance", jump_tolerance),
        )
    }
    settings["direction"] = direction
    key = {"version": DETECTION_VERSION, "log_sha1": hashlib.sha1(run.path.read_bytes()).hexdigest()}
    key["settings"] = settings
    found = _read_cache(cache, key)
    if found is None:
        directions = (direction,) if direction is not None else (1, -1)
        try:
            detection = detect_beam_convention(
                run.log, run.geometry.mount_x, min_range, max_range, jump_tolerance, directions=directions
            )
            found = {"first_beam_angle": _snapped(detection.best.first_beam_angle), "margin": detection.margin}
            found["direction"] = detection.best.direction
        except ValueError as error:
            found = {"error": str(error)}
        if cache is not None:
            cache.parent.mkdir(parents=True, exist_ok=True)
            write_file(cache, json.dumps({**key, **found}, indent=1) + "\n")
    if "error" in found or found["margin"] < CONCLUSIVE_MARGIN:
        reason = found.get("error") or f"margin x{found['margin']:.2f} under x{CONCLUSIVE_MARGIN}"
        return run.geometry, f"{run.geometry_origin} (beam convention detection inconclusive: {reason})"
    geometry = dataclasses.replace(
        run.geometry, first_beam_angle=found["first_beam_angle"], direction=found["direction"]
    )
    return geometry, (
        f"detected from the scans: beam 0 at {math.degrees(geometry.first_beam_angle):.0f} deg, direction "
        f"{geometry.direction:+d} (margin x{found['margin']:.2f}; override with --first-beam-angle, --beam-direction)"
    )


def _snapped(angle: float) -> float:
    """``angle`` (rad) as the nearest quarter turn when within ``SNAP_DEGREES`` of it."""
    quarter = round(angle / (math.pi / 2)) * (math.pi / 2)
    return float(wrap_angle(quarter)) if abs(angle - quarter) <= math.radians(SNAP_DEGREES) else angle


def _read_cache(cache: Path | None, key: dict) -> dict | None:
    """The cached detection for ``key`` (log hash and settings), or None (no file, another log or
    other settings, or an unreadable file)."""
    if cache is None or not cache.is_file():
        return None
    try:
        stored = json.loads(cache.read_text())
    except (OSError, ValueError):
        return None
    if {name: stored.get(name) for name in key} != key:
        return None
    return stored
