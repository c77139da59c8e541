"""How much orebro's pose graph depends on the path it starts from. A log without odometry starts its
graph from the grid filter's best path (``[posegraph] grid_start``), run with the config's seed; here
the graph is built from the grid filter's path with each of seeds 0-4 instead, and scored as run.py
scores it (aligned ATE at the scans against the log's reference poses, and the relation metric),
beside that start path's own (the grid filter's, experiments/carmen_grid/results/table.csv, the same
seed and settings).

Run: ``python -m experiments.carmen_posegraph.orebro_starts [--jobs 2]`` (after experiments/carmen_grid's
run.py); writes results/orebro_starts.csv and results/orebro_starts.md. About 2.5 CPU minutes a seed.
"""

from __future__ import annotations

import argparse

import pandas as pd

from experiments.carmen_grid.run import imported_run, relation_row, slam_config
from experiments.carmen_posegraph.run import GRID_TABLE, write_results
from mazeslam.evaluation.metrics import absolute_trajectory_error
from mazeslam.posegraph.laser_graph import laser_pose_graph
from mazeslam.sweeps.pool import map_parallel

LOG = "orebro"
SEEDS = range(5)


def graph_row(seed: int) -> dict:
    """orebro's pose graph started from the grid filter's path with ``seed``: its aligned ATE (m)."""
    run = imported_run(LOG)
    result = laser_pose_graph(run, slam_config(run).with_seed(seed))
    reference = run.truth[result.scan_records]
    ate = absolute_trajectory_error(result.poses, reference, align=True)
    relations = relation_row(result.poses, reference)
    return {"seed": seed, "graph_ate_m": ate["rmse"], "graph_rel_trans_m": relations["rel_trans_m"]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args()
    table = pd.DataFrame(map_parallel(graph_row, [(seed,) for seed in SEEDS], args.jobs))
    grid = pd.read_csv(GRID_TABLE)
    start = grid[grid.log == LOG].set_index("seed")
    table.insert(1, "start_path_ate_m", table.seed.map(start["ate_rmse_m"]))
    table.insert(3, "start_path_rel_trans_m", table.seed.map(start["rel_trans_m"]))
    caption = (
        "orebro's pose graph started from the grid filter's best path with each filter seed: the start path's "
        "aligned ATE (experiments/carmen_grid/results/table.csv) and the graph's, and their relation metric "
        "(mean translational error over the pairs of scans within 3 m by the reference), against the log's "
        "reference poses (experiments/carmen_posegraph/orebro_starts.py)."
    )
    write_results(table, "orebro_starts", caption)


if __name__ == "__main__":
    main()
