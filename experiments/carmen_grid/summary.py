"""Per log, over the filter seeds in ``results/table.csv``: the median and worst aligned ATE of the
grid filter, the share of seeds within the issue's 0.3 m, the relation metric's median, the slowest
run against the log's duration and the largest peak memory. Writes ``results/summary.md``, and
``results/both_kinds.md``: the grid filter beside corner FastSLAM (``experiments/carmen/results/seeds.csv``),
both scored alike (quoted by docs/grid.md and docs/carmen.md).

    python experiments/carmen_grid/summary.py
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd

RESULTS = Path(__file__).resolve().parent / "results"
CORNERS = Path(__file__).resolve().parents[1] / "carmen" / "results" / "seeds.csv"
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
    summary["CPU s, slowest"] = grouped["cpu_seconds"].max()
    summary["log s"] = grouped["log_seconds"].first()
    summary["peak MB"] = grouped["peak_mb"].max()
    text = (
        "Grid filter (30 particles) on the CARMEN logs, per log over the filter seeds run: aligned ATE of the "
        "best path at the scans against the log's reference poses; the relation metric (Kümmerle et al. 2009: "
        "mean translational and rotational error over the pairs of scans within 3 m of each other by the "
        "reference; median over the seeds); CPU seconds of the slowest seed against the log's duration "
        "(0: the log has no clock); the largest peak memory of the process.\n\n"
        + summary.to_markdown(floatfmt=".3g")
        + "\n"
    )
    (RESULTS / "summary.md").write_text(text)
    print(text)
    if CORNERS.exists():
        corners = per_log(pd.read_csv(CORNERS), "aligned", "rel_trans_m", "rel_rot_deg")
        both = pd.concat(
            {"corner FastSLAM (100 particles)": corners, "grid filter (30 particles)": summary.iloc[:, :6]}, axis=1
        )
        both.columns = [f"{kind}: {column}" for kind, column in both.columns]
        text = (
            "Both map kinds on the CARMEN logs, scored alike at the scans against the logs' reference poses: "
            "aligned ATE (median and worst over the filter seeds) and the relation metric (median over the "
            "seeds). Corner FastSLAM scores its weighted-mean path (experiments/carmen), the grid filter its "
            "best particle's path (experiments/carmen_grid).\n\n" + both.to_markdown(floatfmt=".3g") + "\n"
        )
        (RESULTS / "both_kinds.md").write_text(text)
        print(text)


if __name__ == "__main__":
    main()
