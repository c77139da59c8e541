"""How a filter run did against its log's truth: the one scoring function of ``mazeslam slam``,
sweeps and experiments, for both filters.

Trajectories are scored at the records the filter estimated (``SlamResult.estimated_records``):
every record, or only the scans when the filter moved by laser odometry or mapped a grid (it knows
no pose of its own between two scans). A landmark map is scored as estimated and after the rigid
motion that best aligns the estimated trajectory with the true one (the map shares the
trajectory's frame); a grid map is not scored here (``evaluation.sharpness`` measures it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from mazeslam.data.loaded_run import LoadedRun
from mazeslam.evaluation.consistency import nees_summary
from mazeslam.evaluation.metrics import (
    absolute_trajectory_error,
    align_se2,
    apply_se2,
    map_error,
    normalized_estimation_error,
    relative_pose_error,
)

if TYPE_CHECKING:
    import pandas as pd

    from mazeslam.pipeline.result import SlamResult

#: Stretch of the true path over which the relative pose error is measured, metres.
RPE_DISTANCE = 0.1
#: Dead reckoning's row.
DEAD_RECKONING = "dead reckoning"


#: The columns of an error table, in order: ATE as estimated and aligned (m), RPE (m, rad), NEES.
COLUMNS = (
    "ate_rmse",
    "ate_mean",
    "ate_max",
    "aligned_rmse",
    "aligned_mean",
    "aligned_max",
    "rpe_trans_rmse",
    "rpe_rot_rmse",
)
#: The NEES columns ``score_run`` adds (NaN but for the filter's mean).
NEES_COLUMNS = ("mean_nees", "median_nees")


@dataclass(kw_only=True)
class RunScore:
    """A run's errors against the truth.

    Attributes:
        records: (S,) the record indices scored.
        filter_name: the filter's name; its rows are ``"<name> (mean)"`` (``mean_row``) and
            ``"<name> (best particle)"`` (``best_row``).
        rows: one row per estimator (dead reckoning, laser odometry when used, the filter's mean
            and best particle), each ``COLUMNS`` (``error_rows``) and ``NEES_COLUMNS``: the
            ``mean_nees`` and ``median_nees`` of the filter's mean (NaN in the other rows).
            ``table`` is the same as a pandas DataFrame, ``markdown`` as printed.
        nees: (S,) the mean pose's NEES at each scored record (NaN where undefined);
            nees_summary its mean, median and share inside the 95 % bound (``consistency``).
        alignment: (3,) the rigid motion (x, y, theta) that best maps the mean path onto the truth.
        map_errors: ``{"as estimated": ..., "aligned": ...}`` each ``metrics.map_error``'s dict,
            against the true corners (empty for a grid map).
    """

    records: np.ndarray
    filter_name: str
    rows: dict[str, dict[str, float]]
    nees: np.ndarray
    nees_summary: dict
    alignment: np.ndarray
    map_errors: dict

    @property
    def mean_row(self) -> str:
        """The row of the filter's weighted-mean path."""
        return f"{self.filter_name} (mean)"

    @property
    def best_row(self) -> str:
        """The row of the best particle's path."""
        return f"{self.filter_name} (best particle)"

    @property
    def table(self) -> pd.DataFrame:
        """``rows`` as a DataFrame indexed by ``estimator`` (pandas loads on first use)."""
        return _data_frame(self.rows)

    def ate(self, estimator: str | None = None, aligned: bool = False) -> float:
        """ATE RMSE of one estimator (the filter's mean when None), metres."""
        return float(self.rows[estimator or self.mean_row]["aligned_rmse" if aligned else "ate_rmse"])

    def markdown(self) -> str:
        """The table as ``table.to_markdown(floatfmt=".4f")`` prints it (``markdown_table``)."""
        return markdown_table(self.rows)

    def row_records(self) -> list[dict]:
        """One dict per estimator, its name under ``"estimator"`` then its columns (as
        ``table.reset_index().to_dict(orient="records")``)."""
        return [{"estimator": name, **row} for name, row in self.rows.items()]


def error_rows(estimates: dict[str, np.ndarray], truth: np.ndarray) -> dict[str, dict[str, float]]:
    """ATE (RMSE, mean, max; without and with SE(2) alignment, metres) and RPE over
    ``RPE_DISTANCE`` of path (translation m, rotation rad) of each named trajectory (S, 3): one
    dict of ``COLUMNS`` per name. Plain floats: no pandas (0.3 s to import) on ``mazeslam slam``'s path."""
    rows = {}
    for name, poses in estimates.items():
        raw = absolute_trajectory_error(poses, truth)
        aligned = absolute_trajectory_error(poses, truth, align=True)
        rpe = relative_pose_error(poses, truth, RPE_DISTANCE)
        values = (raw["rmse"], raw["mean"], raw["max"], aligned["rmse"], aligned["mean"], aligned["max"])
        rows[name] = dict(zip(COLUMNS, (*values, rpe["trans_rmse"], rpe["rot_rmse"])))
    return rows


def error_table(estimates: dict[str, np.ndarray], truth: np.ndarray) -> pd.DataFrame:
    """``error_rows`` as a DataFrame indexed by ``estimator``, one row per trajectory."""
    return _data_frame(error_rows(estimates, truth))


def _data_frame(rows: dict[str, dict[str, float]]) -> pd.DataFrame:
    import pandas as pd  # 0.3 s: loaded when a table is first asked for, not with the module

    return pd.DataFrame([{"estimator": name, **row} for name, row in rows.items()]).set_index("estimator")


def markdown_table(rows: dict[str, dict[str, float]], decimals: int = 4) -> str:
    """``rows`` (name -> columns, every row the same columns) as a GitHub markdown table, exactly as
    pandas' ``to_markdown(floatfmt=".4f")`` (tabulate's "pipe" format) prints the same table, without
    loading either: the names left-aligned under ``estimator``, the numbers with ``decimals`` digits
    aligned on their decimal point (NaN and infinities, which have none, end where the digits would
    start), each column at least its header plus two wide."""
    names = list(rows)
    headers = list(rows[names[0]]) if names else []
    name_width = max([len("estimator") + 2, *(len(name) for name in names)])
    columns = [
        _aligned_numbers([rows[name][header] for name in names], len(header) + 2, decimals) for header in headers
    ]
    widths = [name_width] + [len(column[0]) if column else len(header) + 2 for column, header in zip(columns, headers)]
    lines = [
        "| " + " | ".join(["estimator".ljust(name_width)] + [h.rjust(w) for h, w in zip(headers, widths[1:])]) + " |",
        "|" + "|".join([":" + "-" * (name_width + 1)] + ["-" * (w + 1) + ":" for w in widths[1:]]) + "|",
    ]
    for row, name in enumerate(names):
        lines.append("| " + " | ".join([name.ljust(name_width)] + [column[row] for column in columns]) + " |")
    return "\n".join(lines)


def _aligned_numbers(values: list[float], min_width: int, decimals: int) -> list[str]:
    """``values`` formatted to ``decimals`` places, padded on the right to line up their decimal
    points (a value without one, NaN or inf, as if its point followed it), then right-aligned to a
    common width of at least ``min_width``."""
    texts = [format(float(value), f".{decimals}f") for value in values]
    after = [len(text) - text.index(".") - 1 if "." in text else -1 for text in texts]
    texts = [text + " " * (max(after) - places) for text, places in zip(texts, after)]
    width = max([min_width, *(len(text) for text in texts)])
    return [text.rjust(width) for text in texts]


def score_run(run: LoadedRun, result: SlamResult, match_radius: float = 0.05) -> RunScore | None:
    """Score ``result`` against ``run``'s truth at ``result.estimated_records``: dead reckoning,
    laser odometry when the filter moved by it, the filter's mean (with its NEES) and best
    particle; a landmark map against the true corners within ``match_radius`` m. None when the log
    has no truth."""
    if run.truth is None:
        return None
    records = result.estimated_records
    truth = run.truth[records]
    estimates = {DEAD_RECKONING: result.dead_reckoning[records]}
    if result.laser_odometry is not None:
        estimates["laser odometry"] = result.laser_odometry.poses(run.start_pose)
    mean = result.mean_poses[records]
    name = result.filter_name
    estimates.update({f"{name} (mean)": mean, f"{name} (best particle)": result.best_poses[records]})
    rows = error_rows(estimates, truth)
    nees = normalized_estimation_error(mean, result.pose_covariances[records], truth)
    summary = nees_summary(nees)
    for row in rows.values():
        row.update(dict.fromkeys(NEES_COLUMNS, math.nan))
    rows[f"{name} (mean)"].update(
        {
            column: math.nan if summary[key] is None else float(summary[key])
            for column, key in zip(NEES_COLUMNS, ("mean", "median"))
        }
    )
    alignment = align_se2(mean, truth)
    map_errors = {}
    if result.grid is None:
        aligned = apply_se2(alignment, result.landmarks) if len(result.landmarks) else result.landmarks
        map_errors = {
            "as estimated": map_error(result.landmarks, run.true_corners, match_radius),
            "aligned": map_error(aligned, run.true_corners, match_radius),
        }
    return RunScore(
        records=records,
        filter_name=name,
        rows=rows,
        nees=nees,
        nees_summary=summary,
        alignment=alignment,
        map_errors=map_errors,
    )
