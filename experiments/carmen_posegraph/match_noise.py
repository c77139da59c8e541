"""The sequential edges' covariance scale measured on the CARMEN logs with odometry: for each log,
the laser odometry's interval errors against the reference increments, and the factor on the
independent-beam match covariance (``mazeslam.posegraph.sequential``: ``variance_scale``) that brings
their median NEES to chi-square's median for 3 degrees of freedom (2.366), and the intervals' heading
drift: the least-squares slope (through zero) of their heading error on their travel, rad/m, over the
intervals whose heading error is under ``DRIFT_OUTLIER`` (the ``drift_sigma`` of
``mazeslam.posegraph.params.SolveParams``). Intervals whose match was refused are left out (they keep
the prior's covariance).

Run: ``python -m experiments.carmen_posegraph.match_noise``; writes results/match_noise.md.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import scipy.optimize

from experiments.carmen_grid.run import LOGS, imported_run, slam_config
from mazeslam.core.geometry import relative, wrap_angle
from mazeslam.posegraph.params import SequentialParams
from mazeslam.posegraph.sequential import match_covariances
from mazeslam.registration.scan_matching import laser_odometry

RESULTS = Path(__file__).resolve().parent / "results"
CHI2_3_MEDIAN = 2.366
#: Heading errors (rad) above this are a wrong match, not a drift, and are left out of the drift's fit.
DRIFT_OUTLIER = 0.02


def median_nees(scale: float, run, odometry, scan_params, errors: np.ndarray, used: np.ndarray) -> float:
    covariances = match_covariances(
        run.log, run.geometry, odometry, scan_params, SequentialParams(variance_scale=scale)
    )
    nees = np.einsum("ki,kij,kj->k", errors, np.linalg.inv(covariances), errors)
    return float(np.median(nees[used]))


def fitted_scale(run, odometry, scan_params, errors: np.ndarray, used: np.ndarray) -> float:
    """The variance scale whose median NEES over the ``used`` intervals is chi-square's median."""

    def gap(scale: float) -> float:
        return float(np.log(median_nees(scale, run, odometry, scan_params, errors, used) / CHI2_3_MEDIAN))

    return float(scipy.optimize.brentq(gap, 0.1, 1e5))


def heading_drift(errors: np.ndarray, travel: np.ndarray) -> float:
    """The slope (rad/m) of ``errors`` (N,) (rad) on ``travel`` (N,) (m, signed), least squares through
    zero, over the errors below ``DRIFT_OUTLIER``."""
    inlier = np.abs(errors) < DRIFT_OUTLIER
    return float(np.sum(travel[inlier] * errors[inlier]) / np.sum(travel[inlier] ** 2))


def main() -> None:
    rows = []
    for name in LOGS:
        run = imported_run(name)
        if not run.log.is_odometry.any():
            continue
        scan_params = slam_config(run).scan_matching
        odometry = laser_odometry(run.log, run.geometry, scan_params)
        reference = run.truth[odometry.scan_records]
        truth_increments = relative(reference[:-1], reference[1:])
        errors = np.zeros((len(reference), 3))
        errors[1:] = odometry.increments[1:] - truth_increments
        errors[:, 2] = wrap_angle(errors[:, 2])
        used = odometry.accepted.copy()
        used[0] = False
        scale = fitted_scale(run, odometry, scan_params, errors, used)
        travel = np.sign(truth_increments[:, 0]) * np.hypot(*truth_increments[:, :2].T)
        drift = heading_drift(errors[1:, 2][used[1:]], travel[used[1:]])
        row = {"log": name, "intervals": int(used.sum()), "variance_scale": scale, "heading_drift_rad_per_m": drift}
        rows.append(row)
        print(rows[-1], flush=True)
    table = pd.DataFrame(rows)
    drifts = table.heading_drift_rad_per_m
    summary = (
        f"median over the logs: variance_scale {table.variance_scale.median():.3g}; heading drift "
        f"{drifts.median():.3g} rad/m (from {drifts.min():.3g} to {drifts.max():.3g})"
    )
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / "match_noise.md").write_text(
        "# Sequential edges: variance scale of the match covariance and heading drift "
        "(experiments/carmen_posegraph/match_noise.py)\n\n"
        + table.to_markdown(index=False, floatfmt=".3g")
        + f"\n\n{summary}\n"
    )
    print(summary)


if __name__ == "__main__":
    main()
