"""How far apart the CARMEN logs' three estimates of the scan poses are: the reference poses (a
gmapping run), the pose graph's (results/<log>_trajectory.csv, from run.py) and the grid filter's
best paths (experiments/carmen_grid/results/<log>_seed<k>/trajectory.csv, 5 seeds). Each figure is
an aligned ATE (m, RMS after the best rigid motion) between two of them at the scans: graph and
reference, filter and reference (median over the seeds), graph and filter (median over the seeds),
and filter and filter (median over the 10 pairs of seeds). Where the graph and the filter, made by
two different methods, are closer to each other than either is to the reference, the reference's
own error is a large part of what the ATE against it measures (the two share the scans, so an error
both would make from them is not seen).

Run: ``python -m experiments.carmen_posegraph.agreement`` (after run.py and experiments/carmen_grid's
run.py with seeds 0-4); writes results/agreement.csv and .md. A few CPU seconds.
"""

from __future__ import annotations

from itertools import combinations

import numpy as np
import pandas as pd

from experiments.carmen_grid.run import LOGS, imported_run
from experiments.carmen_posegraph.run import RESULTS, write_results
from experiments.carmen_posegraph.sharpness import SEEDS, grid_path
from mazeslam.evaluation.metrics import absolute_trajectory_error


def apart(first: np.ndarray, second: np.ndarray) -> float:
    """Aligned ATE (m) of ``first`` against ``second``, both (S, 3)."""
    return absolute_trajectory_error(first, second, align=True)["rmse"]


def log_row(name: str) -> dict:
    scans = pd.read_csv(RESULTS / f"{name}_trajectory.csv")
    records = scans.record.to_numpy()
    graph = scans[["x", "y", "theta"]].to_numpy()
    reference = imported_run(name).truth[records]
    grids = [grid_path(name, seed)[records] for seed in SEEDS]
    return {
        "log": name,
        "graph_vs_reference_m": apart(graph, reference),
        "grid_vs_reference_m": float(np.median([apart(grid, reference) for grid in grids])),
        "graph_vs_grid_m": float(np.median([apart(graph, grid) for grid in grids])),
        "grid_vs_grid_m": float(np.median([apart(a, b) for a, b in combinations(grids, 2)])),
    }


def main() -> None:
    table = pd.DataFrame([log_row(name) for name in LOGS])
    caption = (
        "Aligned ATE (m) between the CARMEN logs' estimates of the scan poses: the pose graph, the grid filter's "
        "best path (median over 5 seeds) and the reference poses (a gmapping run), and between the filter's "
        "seeds (median over the 10 pairs) (experiments/carmen_posegraph/agreement.py)."
    )
    write_results(table, "agreement", caption)


if __name__ == "__main__":
    main()
