"""The relation metric of Kümmerle et al., "On measuring the accuracy of SLAM algorithms"
(Autonomous Robots 27(4), 2009).

A relation is a pair of poses ``(i, j)`` and the reference motion between them,
``delta*_ij = x*_i (-) x*_j`` (pose ``j`` in the robot frame of pose ``i``). An estimate is scored
by how far its own motion ``delta_ij = x_i (-) x_j`` is from the reference's: the error of a
relation is ``e_ij = delta*_ij (-) delta_ij`` (again a relative pose), its translational part
``|trans(e_ij)|`` (m) and its rotational part ``|rot(e_ij)|`` (rad). The metric is their mean (and
mean square) over the relations. Unlike the ATE it needs no global alignment, and an error made
once (a bent corridor) costs only the relations that span it.

The paper takes its relations from manually verified scan matches between poses near each other
in space (consecutive ones and loop closures), published as text files (``read_relations``: one
relation a line, ``t1 t2 x y z roll pitch yaw``, the motion from the pose at time ``t1`` to the pose
at ``t2`` in the first's frame); ``relations_metric`` scores a trajectory against such a file.
With only reference poses to go by (the CARMEN logs' corrected poses), ``spatial_relations`` takes
every pair of scans whose reference positions are within a radius of each other: consecutive
scans, and revisits of a place however far apart in time.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mazeslam.core.config import InputError, read_text
from mazeslam.core.geometry import relative, wrap_angle

#: Relation radius for building logs with a scan about every metre (the CARMEN logs), m: the few
#: scans before and after each scan and every revisit of its place (loop closures).
BUILDING_RADIUS = 3.0


def spatial_relations(reference: np.ndarray, radius: float, min_gap: int = 1) -> np.ndarray:
    """Pairs (K, 2) of indexes ``i < j`` of ``reference`` poses (S, >=2), world frame, m) whose
    positions are at most ``radius`` m apart and at least ``min_gap`` indexes apart, sorted by
    ``i`` then ``j``."""
    if radius <= 0 or min_gap < 1:
        raise ValueError(f"radius must be positive (m) and min_gap at least 1, got {radius} and {min_gap}")
    positions = np.asarray(reference, dtype=float)[:, :2]
    from scipy.spatial import cKDTree  # here: scipy.spatial is slow to load

    pairs = cKDTree(positions).query_pairs(radius, output_type="ndarray")
    if len(pairs) == 0:
        return np.zeros((0, 2), dtype=int)
    pairs = np.sort(pairs, axis=1)
    pairs = pairs[pairs[:, 1] - pairs[:, 0] >= min_gap]
    return pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]


def relation_errors(estimate: np.ndarray, reference: np.ndarray, pairs: np.ndarray) -> np.ndarray:
    """The error ``e_ij = delta*_ij (-) delta_ij`` (K, 3) of each relation ``pairs`` (K, 2) between
    ``estimate`` and ``reference`` poses (S, 3) (x m, y m, theta rad; any world frame each)."""
    estimate, reference = np.asarray(estimate, dtype=float), np.asarray(reference, dtype=float)
    if estimate.shape != reference.shape or estimate.ndim != 2 or estimate.shape[1] != 3:
        raise ValueError(
            f"estimate and reference must both be (S, 3) poses, got {estimate.shape} and {reference.shape}"
        )
    pairs = np.asarray(pairs, dtype=int).reshape(-1, 2)
    return motion_errors(_motions(estimate, pairs), _motions(reference, pairs))


def _motions(poses: np.ndarray, pairs: np.ndarray) -> np.ndarray:
    """The motion (K, 3) from pose ``i`` to pose ``j`` of each pair (K, 2), in pose ``i``'s frame."""
    return relative(poses[pairs[:, 0]], poses[pairs[:, 1]]).reshape(-1, 3)


def motion_errors(ours: np.ndarray, theirs: np.ndarray) -> np.ndarray:
    """The error ``theirs (-) ours`` (K, 3) of estimated relative motions ``ours`` (K, 3) against the
    reference's ``theirs`` (K, 3) (x m, y m, theta rad; heading wrapped to [-pi, pi))."""
    errors = relative(theirs, ours).reshape(-1, 3)
    errors[:, 2] = wrap_angle(errors[:, 2])
    return errors


def relation_metric(estimate: np.ndarray, reference: np.ndarray, pairs: np.ndarray) -> dict[str, float]:
    """Kümmerle et al.'s metric over the relations ``pairs`` (K, 2) (see ``error_summary``).
    Estimate and reference are (S, 3) poses (see ``relation_errors``)."""
    return error_summary(relation_errors(estimate, reference, pairs))


def error_summary(errors: np.ndarray) -> dict[str, float]:
    """The metric of relation errors (K, 3): the mean, standard deviation and mean square of the
    translational errors (m, m^2) and of the rotational errors (rad, rad^2), and the relation count."""
    if len(errors) == 0:
        raise ValueError("no relations to score")
    translation, rotation = np.hypot(errors[:, 0], errors[:, 1]), np.abs(errors[:, 2])
    return {
        "relations": len(errors),
        "trans_mean": float(translation.mean()),
        "trans_std": float(translation.std()),
        "trans_sq_mean": float(np.mean(translation**2)),
        "rot_mean": float(rotation.mean()),
        "rot_std": float(rotation.std()),
        "rot_sq_mean": float(np.mean(rotation**2)),
    }


@dataclass(frozen=True)
class Relations:
    """Relations read from a file (``read_relations``).

    Attributes:
        first, second: (K,) the times of each relation's two poses, s.
        motions: (K, 3) the reference motion from the first pose to the second, in the first
            pose's frame (x m, y m, yaw rad).
        lines: (K,) each relation's line in the file (1-based), for messages.
        source: the file's name.
    """

    first: np.ndarray
    second: np.ndarray
    motions: np.ndarray
    lines: np.ndarray
    source: str


def read_relations(path: str | Path) -> Relations:
    """Read a relations file in the text format of Kümmerle et al.'s benchmark: one relation a line,
    ``t1 t2 x y z roll pitch yaw`` (s, s, m, m, m, rad, rad, rad); z, roll and pitch are ignored (2-D).
    Blank lines and lines starting with ``#`` are skipped. Errors name the file and the line (a
    line whose two times are equal but whose motion is not zero is one: made from poses without a
    clock)."""
    text = read_text(Path(path), "relations file")
    rows, lines = [], []
    for number, line in enumerate(text.splitlines(), start=1):
        fields = line.split()
        if not fields or fields[0].startswith("#"):
            continue
        if len(fields) != 8:
            raise InputError(f"{path}:{number}: a relation has 8 numbers t1 t2 x y z roll pitch yaw, got {len(fields)}")
        try:
            values = [float(field) for field in fields]
        except ValueError:
            raise InputError(f"{path}:{number}: not a number in {line.strip()[:60]!r}") from None
        if not all(math.isfinite(value) for value in values):
            raise InputError(f"{path}:{number}: every value must be finite")
        if values[0] == values[1] and any(values[i] != 0 for i in (2, 3, 7)):
            raise InputError(
                f"{path}:{number}: a motion between two poses at one time ({values[0]:g} s): relations are "
                "matched by time, so poses without a clock (a log whose scans share one time) cannot be scored"
            )
        rows.append(values)
        lines.append(number)
    if not rows:
        raise InputError(f"{path}: no relations in the file")
    table = np.array(rows)
    return Relations(table[:, 0], table[:, 1], table[:, [2, 3, 7]], np.array(lines), str(path))


def pairs_at_times(
    times: np.ndarray, relations: Relations, max_gap: float, source: str = "the trajectory"
) -> np.ndarray:
    """For each relation, the indexes (K, 2) of the poses at ``times`` (R,) (s, non-decreasing)
    nearest its two times. Errors name ``source`` (the poses' file) or the relation's line: a
    relation time with no pose within ``max_gap`` s (a run that ended early, or another log's
    relations), and a relation whose two times fall on one pose (poses without a clock)."""
    times = np.asarray(times, dtype=float)
    if len(times) == 0:
        raise InputError(f"{source}: no poses to score")
    if np.any(np.diff(times) < 0):
        raise InputError(f"{source}: the times decrease somewhere; relations are matched by time")
    pairs = np.column_stack([_nearest(times, relations.first), _nearest(times, relations.second)])
    gaps = np.abs(times[pairs] - np.column_stack([relations.first, relations.second]))
    missing = np.flatnonzero(gaps.max(axis=1) > max_gap)
    if len(missing):
        row = missing[0]
        wanted = relations.first[row] if gaps[row, 0] > max_gap else relations.second[row]
        raise InputError(
            f"{relations.source}:{relations.lines[row]}: no pose of {source} within {max_gap:g} s of "
            f"t = {wanted:.6f} ({len(missing)} of {len(pairs)} relations so; the poses span "
            f"{times[0]:.6f}-{times[-1]:.6f} s)"
        )
    same = np.flatnonzero((pairs[:, 0] == pairs[:, 1]) & (relations.first != relations.second))
    if len(same):
        raise InputError(
            f"{relations.source}:{relations.lines[same[0]]}: both times of the relation fall on one pose of "
            f"{source} ({len(same)} relations so): its poses share their times (poses without a clock cannot "
            "be matched by time)"
        )
    return pairs


def _nearest(times: np.ndarray, wanted: np.ndarray) -> np.ndarray:
    """Index (K,) of the entry of sorted ``times`` (R,) nearest each of ``wanted`` (K,); of entries
    sharing that time, the last: the latest estimate at that time (a log's scan record comes after
    the odometry record of its time, and a relation refers to the scan)."""
    after = np.searchsorted(times, wanted, side="right")
    before, after = np.maximum(after - 1, 0), np.minimum(after, len(times) - 1)
    later = np.abs(times[after] - wanted) < np.abs(wanted - times[before])
    return np.searchsorted(times, np.where(later, times[after], times[before]), side="right") - 1


def relations_metric(
    times: np.ndarray, poses: np.ndarray, relations: Relations, max_gap: float, source: str = "the trajectory"
) -> dict[str, float]:
    """Kümmerle et al.'s metric (``error_summary``) of the poses (R, 3) at ``times`` (R,) (s; x m,
    y m, theta rad, any world frame) against a relations file's reference motions; errors name
    ``source`` (see ``pairs_at_times``)."""
    pairs = pairs_at_times(times, relations, max_gap, source)
    return error_summary(motion_errors(_motions(np.asarray(poses, dtype=float), pairs), relations.motions))
