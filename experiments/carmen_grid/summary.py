"""Per log, over the filter seeds in ``results/table.csv``: the median and worst aligned ATE of the
grid filter, the share of seeds within the issue's 0.3 m, the relation metric's median, the slowest
run against the log's duration and the largest peak memory. Writes ``results/summary.md``, and
``results/both_kinds.md``: the grid filter beside corner FastSLAM (``experiments/carmen/results/seeds.csv``),
both scored alike (quoted by docs/grid.md and docs/carmen.md). With ``results/table_before.csv`` (the
table of the code before this round's change, ``BEFORE_CODE``), ``results/before_after.md``: the
aligned ATE of the same (log, seed) runs before and after (``CHANGE``).

    python -m experiments.carmen_grid.summary
"""

from __future__ import annotations

import argparse
from pathlib import Path

import pandas as pd

RESULTS = Path(__file__).resolve().parent / "results"
CORNERS = Path(__file__).resolve().parents[1] / "carmen" / "results" / "seeds.csv"
BEFORE = RESULTS / "table_before.csv"
#: What table_before.csv ran, and what changed since (before_after.md's caption).
BEFORE_CODE = "commit 5651635"
CHANGE = (
    "sessions 9-10: each particle's first motion is drawn with noise, and the motion noise is the laser odometry's "
    "measured against the references (0.04, 0.02, 0.008, floor 0.01; 0.1, 0.1, 0.05, floor 0.01 on orebro, "
    "which has no odometry) where it was 0.1, 0.1, 0.05 with a 0.05 floor; and the import moves the reference's "
    "poses before the first scan into the scans' frame (mazeslam.data.carmen.anchored_to_first_scan), which "
    "turns the whole run by that offset (aligned ATE does not see it; a run's random draws then differ)"
)
TARGET = 0.3  # m: issue 17's bound on the worst seed's aligned ATE


def per_log(table: pd.DataFrame, ate: str, translation: str, rotation: str) -> pd.DataFrame:
    """Median and worst aligned ATE, seeds within ``TARGET`` and the median relation errors, per log."""
    grouped = table.groupby("log")
    return pd.DataFrame(
        {
            "seeds": grouped["seed"].apply(lambda seeds: " ".join(str(s) for s in sorted(seeds))),
            "ATE median [m]": grouped[ate].median(),
            "ATE worst [m]": grouped[ate].max(),
            f"within {TARGET} m": grouped[ate].apply(lambda values: f"{(values <= TARGET).sum()} of {len(values)}"),
            "relation trans [m]": grouped[translation].median(),
            "relation rot [deg]": grouped[rotation].median(),
        }
    )


def main() -> None:
    table = pd.read_csv(RESULTS / "table.csv")
    summary = per_log(table, "ate_rmse_m", "rel_trans_m", "rel_rot_deg")
    grouped = table.groupby("log")
    summary["mean path ATE median [m]"] = grouped["ate_mean_path_m"].median()
    summary["NEES median"] = grouped["nees_median"].median()
    summary["NEES inside 95 %"] = grouped["nees_inside_95"].median()
    summary["motion NIS mean"] = grouped["nis_mean"].median()
    summary["motion NIS median"] = grouped["nis_median"].median()
    summary["CPU s, slowest"] = grouped["cpu_seconds"].max()
    summary["log s"] = grouped["log_seconds"].first()
    summary["peak MB"] = grouped["peak_mb"].max()
    text = (
        "Grid filter (30 particles) on the CARMEN logs, per log over the filter seeds run: aligned ATE of the "
        "best path at the scans against the log's reference poses; the relation metric (Kümmerle et al. 2009: "
        "mean translational and rotational error over the pairs of scans within 3 m of each other by the "
        "reference; median over the seeds); the aligned ATE of the cloud's weighted-mean path (median over "
        "the seeds); consistency, medians over the seeds: the mean path's pose NEES against the reference "
        "poses under the covariance the filter states, median over the scans and share inside the 95 % bound "
        "7.81 (consistent: about 2.4 and 95 %; the reference's own errors count as the filter's here) and the "
        "motion NIS over the processed scans, mean and median (the scan match's correction of the laser "
        "odometry against the motion noise; consistent: 3); CPU seconds of the "
        "slowest seed against the log's duration "
        "(0: the log has no clock); the largest peak memory of the process.\n\n"
        + summary.to_markdown(floatfmt=".3g")
        + "\n"
    )
    (RESULTS / "summary.md").write_text(text)
    print(text)
    if CORNERS.exists():
        corners = per_log(pd.read_csv(CORNERS), "aligned", "rel_trans_m", "rel_rot_deg")
        both = pd.DataFrame(
            {
                "corner FastSLAM: aligned ATE median / worst [m]": pair(corners, "ATE median [m]", "ATE worst [m]"),
                "grid filter: aligned ATE median / worst [m]": pair(summary, "ATE median [m]", "ATE worst [m]"),
                f"grid filter: seeds within {TARGET} m": summary[f"within {TARGET} m"],
                "corner FastSLAM: relation error [m] / [deg]": pair(
                    corners, "relation trans [m]", "relation rot [deg]"
                ),
                "grid filter: relation error [m] / [deg]": pair(summary, "relation trans [m]", "relation rot [deg]"),
            }
        )
        text = (
            "Both map kinds on the CARMEN logs (corner FastSLAM: 100 particles, experiments/carmen; grid filter: "
            "30 particles, experiments/carmen_grid), scored alike at the scans against the logs' reference poses: "
            "aligned ATE, median and worst over the filter seeds, and the relation metric (mean translational / "
            "rotational error over the pairs of scans within 3 m by the reference), median over the seeds. "
            "Corner FastSLAM scores its weighted-mean path, the grid filter its best particle's path.\n\n"
            + both.to_markdown()
            + "\n"
        )
        (RESULTS / "both_kinds.md").write_text(text)
        print(text)
    if BEFORE.exists():
        before_after(table, pd.read_csv(BEFORE))


def before_after(after: pd.DataFrame, before: pd.DataFrame) -> None:
    """Aligned ATE of the (log, seed) runs in both tables, before and after: results/before_after.md."""
    both = before.merge(after, on=["log", "seed"], suffixes=(" before", " after"))
    grouped = both.groupby("log")
    rows = pd.DataFrame(
        {
            "seeds": grouped["seed"].apply(lambda seeds: " ".join(str(s) for s in sorted(seeds))),
            "before: ATE per seed [m]": grouped["ate_rmse_m before"].apply(lambda v: " ".join(f"{x:.3g}" for x in v)),
            "after: ATE per seed [m]": grouped["ate_rmse_m after"].apply(lambda v: " ".join(f"{x:.3g}" for x in v)),
            "before: worst [m]": grouped["ate_rmse_m before"].max(),
            "after: worst [m]": grouped["ate_rmse_m after"].max(),
        }
    )
    text = (
        "Grid filter, aligned ATE of the best path against the reference, the same filter seeds before "
        f"(table_before.csv: {BEFORE_CODE}) and after (table.csv: {CHANGE}).\n\n"
        + rows.to_markdown(floatfmt=".3g")
        + "\n"
    )
    (RESULTS / "before_after.md").write_text(text)
    print(text)


def pair(table: pd.DataFrame, first: str, second: str) -> pd.Series:
    """Two columns of ``table`` as one of "first / second" strings, 3 significant digits each."""
    return table[first].map("{:.3g}".format) + " / " + table[second].map("{:.3g}".format)


if __name__ == "__main__":
    # No options; --help says what the script does (it rewrites its committed results).
    argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter).parse_args()
    main()
