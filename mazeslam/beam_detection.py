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

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from mazeslam import log
from mazeslam.beams import BeamGeometry
from mazeslam.geometry import advance_pose, compose, relative, wrap_angle


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
) -> Detection:
    """Score first-beam angles every ``step_degrees`` over the full circle, both directions."""
    if course_log.n_beams is None:
        raise ValueError(f"{course_log.source}: no scans to detect a beam convention from")
    # Full-circle scans (the course logs); a front fan's angles are known from its format.
    n = course_log.width
    pairs = _scan_pairs(course_log, mount_x, jump_tolerance, max_pairs)
    if not pairs:
        raise ValueError(f"{course_log.source}: the robot never moves between two scans; nothing to detect from")
    angles = np.radians(np.arange(0.0, 360.0, step_degrees))
    candidates = []
    for direction in (1, -1):
        bearings = BeamGeometry(first_beam_angle=0.0, direction=direction).bearings(n)  # q: phi0 = 0
        totals = np.zeros(len(angles))
        for (a, b), motion in pairs:
            q_a = _points(course_log.values[a], bearings, min_range, max_range)
            q_b = _points(course_log.values[b], bearings, min_range, max_range)
            if len(q_a) < 3 or len(q_b) < 3:
                continue
            tree = cKDTree(q_a)
            dtheta = motion[2]
            moved = q_b @ np.array([[math.cos(dtheta), math.sin(dtheta)], [-math.sin(dtheta), math.cos(dtheta)]])
            # R(-phi0) t for every phi0: (A, 2)
            cos_p, sin_p = np.cos(angles), np.sin(angles)
            shifts = np.column_stack([cos_p * motion[0] + sin_p * motion[1], -sin_p * motion[0] + cos_p * motion[1]])
            queries = moved[None, :, :] + shifts[:, None, :]  # (A, Q, 2)
            distances, _ = tree.query(queries.reshape(-1, 2))
            totals += np.median(distances.reshape(len(angles), -1), axis=1)
        scores = totals / len(pairs)
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
):
    """Pairs of nearby scans ((record a, record b), sensor motion (dx, dy, dtheta) in a's frame):
    b among the ``window`` scans after a, the sensor moved between ``shortest`` and ``longest``
    metres (enough to tell conventions apart, little enough to see the same walls); the longest
    moves first, at most ``max_pairs``, each scan in at most two pairs."""
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
    pairs.sort(key=lambda p: -math.hypot(p[1][0], p[1][1]))
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
