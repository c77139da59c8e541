"""Is the filter's stated uncertainty right? NEES against truth and NIS on every log.

A consistent estimator's errors are as large as it says: the pose NEES ``e^T P^-1 e`` (3 degrees of
freedom) averages 3 and stays below the chi-square 95 % point 7.81 on 95 % of records, and the
normalised innovation squared of an associated observation (2 degrees of freedom, needs no truth)
averages 2 and stays below 5.99 on 95 % of observations. Much larger values: the filter is
overconfident (its covariance too small); much smaller: underconfident.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import pandas as pd

#: The chi-square 95 % points: the pose (3 dimensions) and an observation (range and bearing):
#: ``scipy.stats.chi2.ppf(0.95, 3 or 2)`` written out, so that importing this module does not load
#: scipy.stats (0.3 s); tests/test_imports.py checks them.
POSE_BOUND_95 = 7.814727903251179
OBSERVATION_BOUND_95 = 5.991464547107979

#: One line for users: what the two numbers mean (corner FastSLAM's NIS: an observation, 2 dof).
EXPLANATION = (
    "NEES (pose error against truth, weighted by the filter's own covariance) and NIS (each "
    "observation's surprise under the filter's prediction) measure whether the filter's stated "
    "uncertainty is right: a consistent filter averages NEES 3 and NIS 2, and about 95 % of values "
    f"fall inside the 95 % bounds ({POSE_BOUND_95:.2f} and {OBSERVATION_BOUND_95:.2f}); far larger "
    "means overconfident."
)
#: The same for the grid filter, whose NIS is the scan match's correction of the motion (3 dof).
MOTION_EXPLANATION = (
    "NEES (pose error against truth, weighted by the filter's own covariance) and the motion NIS (each "
    "scan match's correction of the motion, weighted by the motion noise) measure whether the stated "
    "uncertainty is right: a consistent filter averages NEES 3, and about 95 % of values fall inside "
    f"the 95 % bound {POSE_BOUND_95:.2f}; far larger means overconfident. The motion NIS of a filter "
    "whose matches follow its own map is expected under 3; only far above it is a sure sign of trouble."
)


def summarise(values: np.ndarray, bound: float) -> dict[str, float | int | None]:
    """Mean, median, the fraction of values at or below ``bound`` and the count, over the finite
    values (None where there are none: strict JSON)."""
    finite = np.asarray(values, dtype=float)
    finite = finite[np.isfinite(finite)]
    if not len(finite):
        return {"mean": None, "median": None, "inside_95": None, "count": 0}
    return {
        "mean": float(finite.mean()),
        "median": float(np.median(finite)),
        "inside_95": float(np.mean(finite <= bound)),
        "count": int(len(finite)),
    }


def summary_words(summary: dict, bound: float, consistent: int) -> str:
    """A ``summarise`` result in words: "mean .., median .., ..% inside the 95 % bound .. (consistent:
    ``consistent``)", or "undefined" without values."""
    if not summary["count"]:
        return "undefined"
    return (
        f"mean {summary['mean']:.2f}, median {summary['median']:.2f}, {100 * summary['inside_95']:.0f} % "
        f"inside the 95 % bound {bound:.2f} (consistent: {consistent})"
    )


def nees_summary(nees: np.ndarray) -> dict:
    """``summarise`` of per-record pose NEES (3 degrees of freedom)."""
    return summarise(nees, POSE_BOUND_95)


def nis_summary(nis: np.ndarray) -> dict:
    """``summarise`` of per-observation NIS (2 degrees of freedom)."""
    return summarise(nis, OBSERVATION_BOUND_95)


def map_orientation_spread(means: np.ndarray, exists: np.ndarray, weights: np.ndarray) -> float:
    """How far the particles' maps disagree in orientation: the weighted standard deviation (rad)
    over particles of the angle each particle's map is turned by against the weighted-mean map.

    A particle filter carries the map frame's uncertainty in the world (how far all its landmarks
    may be turned together, since the start) only in the diversity of its particles' maps: once
    resampling has left the particles one common ancestor, this is about 0 while the map as a whole
    may still be turned against the truth, and the pose covariance no longer covers that error
    (Bailey et al., "Consistency of the FastSLAM algorithm", ICRA 2006).

    Args:
        means: (P, M, 2) every particle's landmark positions (m, world frame).
        exists: (P, M) the slot holds a landmark; only the slots every particle holds are compared.
        weights: (P,) normalised particle weights.
    Returns NaN when fewer than two slots are held by every particle. The angle of each particle is
    the 2-D Procrustes rotation of its landmarks about their centroid onto the mean map's.
    """
    common = np.flatnonzero(exists.all(axis=0))
    if len(common) < 2:
        return float("nan")
    spread = means[:, common] - means[:, common].mean(axis=1, keepdims=True)  # (P, C, 2) about each centroid
    reference = np.einsum("p,pcj->cj", weights, spread)  # (C, 2)
    cross = spread[..., 1] @ reference[:, 0] - spread[..., 0] @ reference[:, 1]  # (P,)
    dot = spread[..., 0] @ reference[:, 0] + spread[..., 1] @ reference[:, 1]
    angles = np.arctan2(cross, dot)
    mean = np.average(angles, weights=weights)
    return float(np.sqrt(np.average((angles - mean) ** 2, weights=weights)))


def choose_margin(
    exponents: Sequence[float],
    checks: Sequence[tuple[int, float]],
    runs: Callable[[list[float], int], pd.DataFrame],
    counted: Callable[[pd.DataFrame], pd.Series] | None = None,
) -> tuple[float | None, list[pd.DataFrame]]:
    """The rule that chooses a consistency margin (``[fastslam] likelihood_exponent``) from NEES alone.

    1. Every exponent of ``exponents`` is run at the first check's particle count; those whose worst
       run has a median pose NEES under the check's bar are the candidates, largest (the least
       margin) first.
    2. Each later check runs the candidates at its own particle count, largest first, until one
       stays under its bar; that one is the only candidate left.

    Args:
        exponents: the exponents to try, largest first.
        checks: (particle count, bar) pairs, in order.
        runs: ``runs(exponents, particles)``: a table with one row per run and at least the columns
            ``likelihood_exponent`` and ``median_nees``.
        counted: which rows of a table count for the bars (a boolean Series); all by default (rows
            left out are runs shown beside, such as a held-out log).

    Returns the chosen exponent (None when none passes every check) and every table run, in order.
    """
    (particles, bar), *later = checks
    tables = [runs(list(exponents), particles)]
    candidates = _passing(tables[0], bar, counted)
    for particles, bar in later:
        survivors = []
        for exponent in candidates:
            tables.append(runs([exponent], particles))
            if _passing(tables[-1], bar, counted):
                survivors = [exponent]
                break
        candidates = survivors
    return (candidates[0] if candidates else None), tables


def _passing(table: pd.DataFrame, bar: float, counted) -> list[float]:
    """The exponents of ``table``, largest first, whose counted runs' largest median NEES is under ``bar``."""
    rows = table if counted is None else table[counted(table)]
    worst = rows.groupby("likelihood_exponent")["median_nees"].max()
    return sorted((float(exponent) for exponent in worst[worst < bar].index), reverse=True)
