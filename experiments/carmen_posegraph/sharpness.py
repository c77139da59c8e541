"""The CARMEN logs' scans placed by three paths, without the reference as judge: the reference poses
(a gmapping run's), the pose graph's (results/<log>_trajectory.csv, from run.py) and the grid
filter's best path (experiments/carmen_grid/results/<log>_seed<k>/trajectory.csv, 5 seeds). The
measure is ``mazeslam.evaluation.sharpness``'s: the distinct occupied cells of the returns placed by
a path, fewer = sharper walls, with the path's extent beside it (a shrunken path also looks
sharper). Cells of 0.05 m (the grid's) and returns of 0.1-8 m (a degree of heading error moves a
wall 3 m away by a cell, one 8 m away by three; farther returns are sparse).

Each figure is a ratio to the reference's: where the graph's or the filter's map is sharper than the
reference's, the reference's own errors are part of what the aligned ATE against it measures.

The same count, locally, where the graph and the reference disagree: for each stretch of scans the
graph places more than 0.3 m from the reference (after alignment; ``error_anatomy.stretches``), the
returns of every scan within ``NEAR`` m of the stretch by the reference (the stretch and the other
visits of the place), placed by the graph and by the reference. A ratio well below the log's as a
whole says the reference's walls there are the blurred ones; near 1, the measure cannot tell (in a
corridor two placements metres apart can draw the same walls).

Run: ``python -m experiments.carmen_posegraph.sharpness [--logs orebro ...]`` (after run.py and
experiments/carmen_grid's run.py of those logs); writes results/sharpness.csv and .md, and
results/stretch_sharpness.csv and .md (the rows of the logs not run kept). About 30 CPU s.
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import numpy as np
import pandas as pd

from experiments.carmen_grid.run import LOGS, imported_run, with_rows_kept
from experiments.carmen_posegraph.error_anatomy import stretches
from experiments.carmen_posegraph.run import RESULTS, write_results
from mazeslam.data.loaded_run import LoadedRun
from mazeslam.evaluation.metrics import align_se2, apply_se2
from mazeslam.evaluation.sharpness import occupied_cells, path_extent

GRID_RESULTS = Path(__file__).resolve().parents[1] / "carmen_grid" / "results"
SEEDS = range(5)
CELL, MIN_RANGE, MAX_RANGE = 0.05, 0.1, 8.0
#: The scans within this distance (m) of a stretch's centre, by the reference, make its local map.
NEAR = 6.0


def graph_path(name: str, reference: np.ndarray) -> np.ndarray:
    """The pose graph's poses (R, 3) at the log's scan records (other records keep the reference's:
    only scans are placed)."""
    scans = pd.read_csv(RESULTS / f"{name}_trajectory.csv")
    poses = reference.copy()
    poses[scans.record.to_numpy()] = scans[["x", "y", "theta"]].to_numpy()
    return poses


def grid_path(name: str, seed: int) -> np.ndarray:
    """The grid filter's best path (R, 3), every record."""
    return pd.read_csv(GRID_RESULTS / f"{name}_seed{seed}" / "trajectory.csv")[["x", "y", "theta"]].to_numpy()


def log_row(name: str) -> dict:
    run = imported_run(name)
    reference = run.truth
    paths = {"graph": graph_path(name, reference), **{f"grid{seed}": grid_path(name, seed) for seed in SEEDS}}

    def cells(poses: np.ndarray) -> int:
        return occupied_cells(run.log, poses, run.geometry, MIN_RANGE, MAX_RANGE, CELL)

    reference_cells, reference_extent = cells(reference), path_extent(reference)
    ratios = {key: cells(poses) / reference_cells for key, poses in paths.items()}
    extents = {key: path_extent(poses) / reference_extent for key, poses in paths.items()}
    grid = [ratios[f"grid{seed}"] for seed in SEEDS]
    return {
        "log": name,
        "reference_cells": reference_cells,
        "graph_ratio": ratios["graph"],
        "grid_ratio_best": min(grid),
        "grid_ratio_median": float(np.median(grid)),
        "grid_ratio_worst": max(grid),
        "graph_extent_ratio": extents["graph"],
        "grid_extent_ratio_median": float(np.median([extents[f"grid{seed}"] for seed in SEEDS])),
    }


def local_cells(run: LoadedRun, poses: np.ndarray, records: np.ndarray) -> int:
    """Occupied cells of the returns of the scans ``records`` (K,) alone placed by ``poses`` (R, 3)."""
    values = run.log.values.copy()
    values[run.log.is_scan & ~np.isin(np.arange(len(values)), records)] = 0.0  # 0: no return
    log = dataclasses.replace(run.log, values=values)
    return occupied_cells(log, poses, run.geometry, MIN_RANGE, MAX_RANGE, CELL)


def stretch_rows(name: str) -> list[dict]:
    """Per stretch of the graph's scans more than 0.3 m off the reference: the local map's cells
    placed by the reference and by the graph (module docstring)."""
    run = imported_run(name)
    reference = run.truth
    scans = pd.read_csv(RESULTS / f"{name}_trajectory.csv")
    records, graph = scans.record.to_numpy(), scans[["x", "y", "theta"]].to_numpy()
    moved = apply_se2(align_se2(graph, reference[records]), graph)
    errors = np.hypot(*(moved[:, :2] - reference[records, :2]).T)
    placed = graph_path(name, reference)
    rows = []
    for first, last, largest in stretches(errors):
        centre = reference[records[first : last + 1], :2].mean(axis=0)
        near = records[np.hypot(*(reference[records, :2] - centre).T) < NEAR]
        reference_cells, graph_cells = local_cells(run, reference, near), local_cells(run, placed, near)
        rows.append(
            {
                "log": name,
                "scans": f"{first}-{last}" if last > first else str(first),
                "largest_error_m": largest,
                "scans_near": len(near),
                "reference_cells": reference_cells,
                "graph_cells": graph_cells,
                "graph_ratio": graph_cells / reference_cells,
            }
        )
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--logs", nargs="+", default=LOGS, choices=LOGS)
    logs = parser.parse_args().logs
    table = with_rows_kept(pd.DataFrame([log_row(name) for name in logs]), RESULTS / "sharpness.csv", ["log"])
    caption = (
        "Occupied 0.05 m cells of each CARMEN log's returns (0.1-8 m) placed by the pose graph and by the grid "
        "filter's best path (5 seeds: best, median, worst), as a ratio to the same count along the reference "
        "poses (below 1: sharper walls than the reference's); the paths' extents (bounding-box diagonal) as a "
        "ratio to the reference's (experiments/carmen_posegraph/sharpness.py)."
    )
    write_results(table, "sharpness", caption)
    local = pd.DataFrame([row for name in logs for row in stretch_rows(name)])
    local = with_rows_kept(local, RESULTS / "stretch_sharpness.csv", ["log"], dtype={"scans": str})
    caption = (
        f"Where the pose graph is more than 0.3 m from the reference (aligned): the occupied 0.05 m cells of the "
        f"returns (0.1-8 m) of every scan within {NEAR:g} m of the stretch by the reference, placed by the graph and "
        "by the reference, and their ratio, beside the log's whole-map ratio in sharpness.md "
        "(experiments/carmen_posegraph/sharpness.py)."
    )
    write_results(local, "stretch_sharpness", caption)


if __name__ == "__main__":
    main()
