"""Per log, over the filter seeds in ``results/table.csv``: the median and worst aligned ATE of the
grid filter, the share of seeds within the issue's 0.3 m, and the slowest run against the log's
duration. Writes ``results/summary.md`` (quoted by docs/grid.md).

    python experiments/carmen_grid/summary.py
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd

RESULTS = Path(__file__).resolve().parent / "results"
TARGET = 0.3  # m: issue 17's bound on the worst seed's aligned ATE


def main() -> None:
    table = pd.read_csv(RESULTS / "table.csv")
    grouped = table.groupby("log")
    summary = pd.DataFrame(
        {
            "seeds": grouped["seed"].apply(lambda seeds: " ".join(str(s) for s in sorted(seeds))),
            "ATE median [m]": grouped["ate_rmse_m"].median(),
            "ATE worst [m]": grouped["ate_rmse_m"].max(),
            f"seeds within {TARGET} m": grouped["ate_rmse_m"].apply(
                lambda ate: f"{(ate <= TARGET).sum()} of {len(ate)}"
            ),
            "CPU s, slowest": grouped["cpu_seconds"].max(),
            "log s": grouped["log_seconds"].first(),
        }
    )
    text = (
        "Grid filter (30 particles) on the CARMEN logs, per log over the filter seeds run: aligned ATE of the "
        "best path at the scans against the log's reference poses; CPU seconds of the slowest seed against "
        "the log's duration (0: the log has no clock).\n\n" + summary.to_markdown(floatfmt=".3g") + "\n"
    )
    (RESULTS / "summary.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
