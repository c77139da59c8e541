"""The pose graph (mazeslam.posegraph) on the 8 CARMEN building logs: aligned ATE at the scans against
the logs' reference poses, the relation metric (Kümmerle et al. 2009, as experiments/carmen_grid
scores it: ``relation_row``), the local and closure matches tried, accepted by the ambiguity test and
kept by the robust solve, chi2/dof of the final solve, the pose NEES against the reference poses
(with the covariances the graph states, world frame; the reference is another SLAM estimate, its errors
count as the graph's), CPU seconds against the log's duration and the process's peak memory.

Settings: ``mazeslam.posegraph.laser_graph.PoseGraphParams``'s defaults, and configs/carmen.toml's
``[scan_matching]`` for the laser odometry (configs/carmen_without_odometry.toml for orebro, which
has no odometry records: ``slam_config``), as experiments/carmen_grid runs the grid filter. The graph
makes no random draws (on orebro it starts from the grid filter's path, seeded by the config): one
run per log.

Run: ``python -m experiments.carmen_posegraph.run [--logs aces csail ...] [--jobs 1]``. Each log runs
in a process of its own, so that its peak memory is its own. Results: results/table.csv and
results/summary.md (with the grid filter's ATE from experiments/carmen_grid/results/table.csv beside),
and results/<log>_trajectory.csv (the pose at each scan: record index, x, y, theta).
"""

from __future__ import annotations

import argparse
import dataclasses
import resource
import time
from pathlib import Path

import numpy as np
import pandas as pd

from experiments.carmen_grid.run import LOGS, imported_run, relation_row, run_jobs, slam_config
from mazeslam.evaluation.consistency import nees_summary
from mazeslam.evaluation.metrics import absolute_trajectory_error, normalized_estimation_error
from mazeslam.posegraph.graph import EdgeKind
from mazeslam.posegraph.laser_graph import PoseGraphResult, laser_pose_graph
from mazeslam.posegraph.params import PoseGraphParams
from mazeslam.posegraph.solve import solve_graph

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "results"
GRID_TABLE = HERE.parent / "carmen_grid" / "results" / "table.csv"


def write_results(table: pd.DataFrame, name: str, caption: str) -> None:
    """``table`` as results/<name>.csv and as results/<name>.md under ``caption`` (a paragraph), and
    printed."""
    table.to_csv(RESULTS / f"{name}.csv", index=False, float_format="%.4f")
    (RESULTS / f"{name}.md").write_text(caption + "\n\n" + table.to_markdown(index=False, floatfmt=".4g") + "\n")
    print(table.to_string())


def run_one(name: str) -> dict:
    """Import one log, build and solve its pose graph, score it against the reference poses."""
    run = imported_run(name)
    loaded_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    began, began_cpu = time.perf_counter(), time.process_time()
    result = laser_pose_graph(run, slam_config(run))
    seconds, cpu_seconds = time.perf_counter() - began, time.process_time() - began_cpu
    reference = run.truth[result.scan_records]
    ate = absolute_trajectory_error(result.poses, reference, align=True)
    nees = nees_summary(normalized_estimation_error(result.poses, result.covariances, reference))
    trajectory = pd.DataFrame(result.poses, columns=["x", "y", "theta"])
    trajectory.insert(0, "record", result.scan_records)
    trajectory.to_csv(RESULTS / f"{name}_trajectory.csv", index=False, float_format="%.5f")
    return {
        "log": name,
        "scans": len(result.scan_records),
        "ate_rmse_m": ate["rmse"],
        "ate_max_m": ate["max"],
        "odometry_ate_m": absolute_trajectory_error(result.odometry_poses, reference, align=True)["rmse"],
        **relation_row(result.poses, reference),
        "local_tried": result.tried["local"],
        "local_accepted": result.accepted["local"],
        "local_kept": result.kept(EdgeKind.LOCAL),
        "closures_tried": result.tried["closure"],
        "closures_accepted": result.accepted["closure"],
        "closures_kept": result.kept(EdgeKind.CLOSURE),
        "closures_rejected": result.rejected(EdgeKind.CLOSURE),
        "blind_dropped": result.rejected(EdgeKind.BLIND),
        "refused_overlap": result.refused["overlap"],
        "refused_ambiguous": result.refused["ambiguous"],
        "refused_degenerate": result.refused["degenerate"],
        "edges": len(result.graph),
        "chi2_per_dof": result.chi2_per_dof,
        "drift_mrad_per_m": 1000 * result.solution.drift,
        "drift_sigma_mrad_per_m": 1000 * result.solution.drift_sigma,
        "ate_drift_held_m": drift_held_ate(result, reference),
        "nees_median": nees["median"],
        "nees_inside_95": nees["inside_95"],
        "passes": result.passes,
        "seconds": seconds,
        "cpu_seconds": cpu_seconds,
        "log_seconds": run.log.duration,
        "loaded_mb": loaded_mb,
        "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
    }


def drift_held_ate(result: PoseGraphResult, reference: np.ndarray) -> float:
    """The aligned ATE (m) against ``reference`` (S, 3) of the same graph solved again from its
    solution with the scan matches' heading drift held at 0 (``drift_sigma`` = 0)."""
    held = dataclasses.replace(PoseGraphParams().solve, drift_sigma=0.0)
    poses = solve_graph(result.graph, result.poses, held, covariances=False).poses
    return absolute_trajectory_error(poses, reference, align=True)["rmse"]


def summary(table: pd.DataFrame) -> str:
    """The Markdown summary: per log the graph's ATE beside the grid filter's median and worst over
    its seeds, the matches, consistency, time and memory."""
    grid = pd.read_csv(GRID_TABLE).groupby("log")["ate_rmse_m"].agg(["median", "max"]) if GRID_TABLE.exists() else None
    rows = []
    for row in table.itertuples():
        rows.append(
            {
                "log": row.log,
                "scans": row.scans,
                "ATE [m]": row.ate_rmse_m,
                "grid filter ATE median / worst [m]": (
                    f"{grid.loc[row.log, 'median']:.3f} / {grid.loc[row.log, 'max']:.3f}"
                    if grid is not None and row.log in grid.index
                    else ""
                ),
                "laser odometry ATE [m]": row.odometry_ate_m,
                "relation trans [m]": row.rel_trans_m,
                "relation rot [deg]": row.rel_rot_deg,
                "local kept / tried": f"{row.local_kept} / {row.local_tried}",
                "closures kept / accepted / tried": (
                    f"{row.closures_kept} / {row.closures_accepted} / {row.closures_tried}"
                ),
                "chi2/dof": row.chi2_per_dof,
                "drift [mrad/m]": f"{row.drift_mrad_per_m:+.3f} +/- {row.drift_sigma_mrad_per_m:.3f}",
                "ATE, drift held at 0 [m]": row.ate_drift_held_m,
                "NEES median": row.nees_median,
                "CPU s": row.cpu_seconds,
                "log s": row.log_seconds,
                "peak MB": row.peak_mb,
            }
        )
    ate = table.ate_rmse_m
    head = (
        "Pose graph (mazeslam.posegraph, experiments/carmen_posegraph/run.py) on the CARMEN logs: aligned ATE at "
        "the scans against the log's reference poses, the grid filter's (experiments/carmen_grid, 5 seeds) beside "
        "it; the laser odometry chained; the relation metric (pairs of scans within 3 m by the reference); the "
        "local and closure matches (kept by the robust solve / accepted by the ambiguity test / tried); chi2 per "
        "degree of freedom of the final solve; the scan matches' heading drift the solve estimates, and the ATE of "
        "the same graph solved with it held at 0; the pose NEES against the reference (unaligned, with the covariances "
        "the graph states; consistent: median 2.4; the reference's own errors count); CPU seconds against the "
        "log's duration (0: no clock); peak memory of the process.\n\n"
        f"Median ATE over the logs: {ate.median():.3f} m; worst: {ate.max():.3f} m ({table.log[ate.idxmax()]}).\n\n"
    )
    return head + pd.DataFrame(rows).to_markdown(index=False, floatfmt=".3g") + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--logs", nargs="+", default=LOGS)
    parser.add_argument("--jobs", type=int, default=1)
    parser.add_argument(
        "--summary-only",
        action="store_true",
        help="rewrite results/summary.md from results/table.csv without running (after experiments/carmen_grid reruns)",
    )
    args = parser.parse_args()
    RESULTS.mkdir(parents=True, exist_ok=True)
    path = RESULTS / "table.csv"
    if not args.summary_only:
        run_jobs(run_one, [(name,) for name in args.logs], args.jobs, path, ["log"])
    (RESULTS / "summary.md").write_text(summary(pd.read_csv(path)))


if __name__ == "__main__":
    main()
