"""How a filter run did against its log's truth: the one scoring function of ``mazeslam slam``
and of sweeps.

Trajectories are scored at every record, or only at the scans when the filter moved by laser
odometry (it knows no pose between two scans). The map is scored as estimated and after the rigid
motion that best aligns the estimated trajectory with the true one (the map shares the
trajectory's frame).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from mazeslam.evaluation.consistency import nees_summary
from mazeslam.evaluation.metrics import (
    absolute_trajectory_error,
    align_se2,
    apply_se2,
    map_error,
    normalized_estimation_error,
    relative_pose_error,
)
from mazeslam.filters.motion import dead_reckoning
from mazeslam.loaded_run import LoadedRun
from mazeslam.slam import SlamResult

if TYPE_CHECKING:
    import pandas as pd

#: Stretch of the true path over which the relative pose error is measured, metres.
RPE_DISTANCE = 0.1
#: The estimator row of the filter's weighted-mean path in ``RunScore.table``.
FILTER_MEAN = "FastSLAM (mean)"
#: Dead reckoning's row.
DEAD_RECKONING = "dead reckoning"


@dataclass
class RunScore:
    """A run's errors against the truth.

    Attributes:
        records: (S,) the record indices scored.
        table: one row per estimator (dead reckoning, laser odometry when used, the filter's mean
            and best particle): ATE (RMSE, mean, max; as estimated and ``aligned_*``, metres), RPE
            over ``RPE_DISTANCE`` (translation m, rotation rad), ``mean_nees`` and
            ``median_nees`` for the filter's mean.
        nees: (S,) the mean pose's NEES at each scored record (NaN where undefined);
            nees_summary its mean, median and share inside the 95 % bound (``consistency``).
        alignment: (3,) the rigid motion (x, y, theta) that best maps the mean path onto the truth.
        map_errors: ``{"as estimated": ..., "aligned": ...}`` each ``metrics.map_error``'s dict,
            against the true corners (empty when the log has none).
    """

    records: np.ndarray
    table: pd.DataFrame
    nees: np.ndarray
    nees_summary: dict
    alignment: np.ndarray
    map_errors: dict

    def ate(self, estimator: str = FILTER_MEAN, aligned: bool = False) -> float:
        """ATE RMSE of one estimator, metres."""
        return float(self.table.loc[estimator, "aligned_rmse" if aligned else "ate_rmse"])


def error_table(estimates: dict[str, np.ndarray], truth: np.ndarray) -> pd.DataFrame:
    """ATE (RMSE, mean, max; without and with SE(2) alignment, metres) and RPE over
    ``RPE_DISTANCE`` of path (translation m, rotation rad) of each named trajectory (S, 3)."""
    import pandas as pd  # 0.5 s: loaded when a run is first scored, not with the module

    rows = []
    for name, poses in estimates.items():
        raw = absolute_trajectory_error(poses, truth)
        aligned = absolute_trajectory_error(poses, truth, align=True)
        rpe = relative_pose_error(poses, truth, RPE_DISTANCE)
        rows.append(
            {
                "estimator": name,
                "ate_rmse": raw["rmse"],
                "ate_mean": raw["mean"],
                "ate_max": raw["max"],
                "aligned_rmse": aligned["rmse"],
                "aligned_mean": aligned["mean"],
                "aligned_max": aligned["max"],
                "rpe_trans_rmse": rpe["trans_rmse"],
                "rpe_rot_rmse": rpe["rot_rmse"],
            }
        )
    return pd.DataFrame(rows).set_index("estimator")


def score_run(run: LoadedRun, result: SlamResult, match_radius: float = 0.05) -> RunScore | None:
    """Score ``result`` against ``run``'s truth; None when the log has no truth."""
    if run.truth is None:
        return None
    laser = result.laser_odometry
    records = laser.scan_records if laser is not None else np.arange(len(run.log))
    truth = run.truth[records]
    # Dead reckoning leaves out the odometry records the filter left out (glitches), as the filter moves.
    reckoned = dead_reckoning(run.log_without([r.index for r in result.dropped_odometry]), run.start_pose)
    estimates = {DEAD_RECKONING: reckoned[records]}
    if laser is not None:
        estimates["laser odometry"] = laser.poses(run.start_pose)
    mean = result.mean_poses[records]
    estimates.update({FILTER_MEAN: mean, "FastSLAM (best particle)": result.best_poses[records]})
    table = error_table(estimates, truth)
    nees = normalized_estimation_error(mean, result.pose_covariances[records], truth)
    table["mean_nees"] = table["median_nees"] = np.nan
    summary = nees_summary(nees)
    table.loc[FILTER_MEAN, ["mean_nees", "median_nees"]] = [
        np.nan if summary[key] is None else summary[key] for key in ("mean", "median")
    ]
    alignment = align_se2(mean, truth)
    aligned = apply_se2(alignment, result.landmarks) if len(result.landmarks) else result.landmarks
    map_errors = {
        "as estimated": map_error(result.landmarks, run.true_corners, match_radius),
        "aligned": map_error(aligned, run.true_corners, match_radius),
    }
    return RunScore(records, table, nees, summary, alignment, map_errors)
