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
in space (consecutive ones and loop closures). With only reference poses to go by (the CARMEN
logs' corrected poses), ``spatial_relations`` takes every pair of scans whose reference positions
are within a radius of each other: consecutive scans, and revisits of a place however far apart in
time.
"""

from __future__ import annotations

import numpy as np

from mazeslam.geometry import relative, wrap_angle

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
    ours = relative(estimate[pairs[:, 0]], estimate[pairs[:, 1]]).reshape(-1, 3)
    theirs = relative(reference[pairs[:, 0]], reference[pairs[:, 1]]).reshape(-1, 3)
    errors = relative(theirs, ours).reshape(-1, 3)
    errors[:, 2] = wrap_angle(errors[:, 2])
    return errors


def relation_metric(estimate: np.ndarray, reference: np.ndarray, pairs: np.ndarray) -> dict[str, float]:
    """Kümmerle et al.'s metric over the relations ``pairs`` (K, 2): the mean, standard deviation
    and mean square of the translational errors (m, m^2) and of the rotational errors (rad,
    rad^2), and the relation count. Estimate and reference are (S, 3) poses (see ``relation_errors``)."""
    errors = relation_errors(estimate, reference, pairs)
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
