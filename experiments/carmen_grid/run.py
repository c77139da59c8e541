"""The grid filter (mazeslam.gridslam) on the 8 CARMEN building logs: aligned ATE at the scans against
the logs' reference poses, the relation metric (Kümmerle et al. 2009, ``mazeslam.evaluation.relations``:
mean translational and rotational error over every pair of scans whose reference positions are within
``BUILDING_RADIUS`` = 3 m), wall-clock and CPU seconds against the log's duration, peak memory, and the best
particle's map (map_server YAML + PGM + PNG) beside each log's own picture. Consistency: the pose NEES
of the cloud's mean against the reference poses (with the covariance the filter states; the reference
is another SLAM estimate, not the truth, and its own errors count as the filter's here) and the motion NIS at the
processed scans (``mazeslam.gridslam.filter.motion_nis``: the scan match's correction against the motion
noise, needs no reference).

The filter's settings are configs/carmen.toml's ``[grid]`` (and ``[scan_matching]`` for the laser
odometry), as ``mazeslam slam LOG --config configs/carmen.toml`` runs them, with the seed replaced;
on a log without odometry records (orebro) configs/carmen_without_odometry.toml's (``slam_config``).

Run: ``python -m experiments.carmen_grid.run [--seeds 0 1 2 3 4] [--logs aces csail ...] [--jobs 2]``.
Each (log, seed) runs in a process of its own (one core each), so that its peak memory is its own.
Results: ``experiments/carmen_grid/results/table.csv`` and ``results/<log>_seed<k>/``. Memory: the
process's peak after importing and reading the log (``loaded_mb``; the log's text parsed into
floats dominates it for the large logs) and after the filter (``peak_mb``), and the most the
particles' maps held together (``map_mb``, shared tiles once).
"""

from __future__ import annotations

import argparse
import resource
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd

from mazeslam.data.carmen import import_carmen
from mazeslam.data.loaded_run import LoadedRun, load_run
from mazeslam.data.map_io import write_map
from mazeslam.data.sidecars import write_trajectory
from mazeslam.evaluation.consistency import nees_summary
from mazeslam.evaluation.metrics import absolute_trajectory_error, normalized_estimation_error
from mazeslam.evaluation.relations import BUILDING_RADIUS, relation_metric, spatial_relations
from mazeslam.gridslam.occupancy import grid_states
from mazeslam.pipeline import SlamConfig, load_slam_config, run_slam
from mazeslam.sweeps.pool import map_parallel

CARMEN = Path(__file__).resolve().parents[3] / "shared" / "data" / "carmen"
CONFIG = Path(__file__).resolve().parents[2] / "configs" / "carmen.toml"
#: The settings of a log without odometry records: carmen.toml's but the grid filter's motion.
CONFIG_WITHOUT_ODOMETRY = CONFIG.with_name("carmen_without_odometry.toml")
RESULTS = Path(__file__).resolve().parent / "results"
LOGS = ["aces", "csail", "edmonton", "fhw", "freiburg-079", "freiburg-101", "orebro", "seattle"]


def relation_row(poses: np.ndarray, reference: np.ndarray) -> dict:
    """The relation metric's columns for ``poses`` (S, 3) against the ``reference`` (S, 3) at the scans."""
    metric = relation_metric(poses, reference, spatial_relations(reference, BUILDING_RADIUS))
    return {
        "relations": metric["relations"],
        "rel_trans_m": metric["trans_mean"],
        "rel_trans_std_m": metric["trans_std"],
        "rel_rot_deg": np.degrees(metric["rot_mean"]),
        "rel_rot_std_deg": np.degrees(metric["rot_std"]),
    }


def imported_run(name: str) -> LoadedRun:
    """The CARMEN log ``name`` (e.g. "aces") imported as ``mazeslam import carmen`` does and loaded."""
    with tempfile.TemporaryDirectory() as folder:
        course = Path(folder) / f"{name}.log"
        import_carmen(CARMEN / f"{name}-corrected.log.gz", course)
        return load_run(course)


def slam_config(run: LoadedRun) -> SlamConfig:
    """configs/carmen.toml, or configs/carmen_without_odometry.toml for a log without odometry records
    (orebro), as docs/carmen.md runs them."""
    return load_slam_config(CONFIG if run.log.is_odometry.any() else CONFIG_WITHOUT_ODOMETRY)


def run_one(name: str, seed: int) -> dict:
    """Import one log, run the grid filter with one seed, write its map and trajectory."""
    run = imported_run(name)
    loaded_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    began, began_cpu = time.perf_counter(), time.process_time()
    result = run_slam(run, slam_config(run).with_seed(seed), progress=False)
    seconds, cpu_seconds = time.perf_counter() - began, time.process_time() - began_cpu
    scans = result.grid_run  # the grid filter's own record, per scan
    reference = run.truth[scans.scan_records]
    ate = absolute_trajectory_error(scans.best_poses, reference, align=True)
    nees = nees_summary(normalized_estimation_error(scans.mean_poses, scans.covariances, reference))
    out = RESULTS / f"{name}_seed{seed}"
    out.mkdir(parents=True, exist_ok=True)
    write_map(grid_states(result.grid), out)
    write_trajectory(out / "trajectory.csv", run.log.times, result.best_poses, result.pose_covariances)
    return {
        "log": name,
        "seed": seed,
        "scans": len(scans.scan_records),
        "processed": int(scans.processed.sum()),
        "ate_rmse_m": ate["rmse"],
        "ate_max_m": ate["max"],
        "ate_mean_path_m": absolute_trajectory_error(scans.mean_poses, reference, align=True)["rmse"],
        "nees_median": nees["median"],
        "nees_inside_95": nees["inside_95"],
        "nis_mean": float(np.mean(result.nis)),
        "nis_median": float(np.median(result.nis)),
        **relation_row(scans.best_poses, reference),
        "seconds": seconds,
        "cpu_seconds": cpu_seconds,
        "log_seconds": run.log.duration,
        "resamplings": result.resamplings,
        "matched": float(np.nanmean(scans.matched)),
        "map_mb": scans.peak_map_bytes / 2**20,
        "loaded_mb": loaded_mb,
        "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--logs", nargs="+", default=LOGS)
    parser.add_argument("--seeds", nargs="+", type=int, default=[0])
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args()
    jobs = [(name, seed) for name in args.logs for seed in args.seeds]
    run_jobs(run_one, jobs, args.jobs, RESULTS / "table.csv", ["log", "seed"])


def with_rows_kept(table: pd.DataFrame, path: Path, keys: list[str], dtype: dict | None = None) -> pd.DataFrame:
    """``table``'s rows and those of the CSV ``path`` (read with ``dtype``) whose ``keys`` it does not
    hold (a run of some logs or seeds keeps the others'), sorted by ``keys`` (stable: rows sharing
    keys keep their order)."""
    if path.exists():
        old = pd.read_csv(path, dtype=dtype)
        keep = ~old.set_index(keys).index.isin(table.set_index(keys).index)
        table = pd.concat([old[keep], table])
    return table.sort_values(keys, kind="stable").reset_index(drop=True)


def run_jobs(worker: Callable[..., dict], jobs: list[tuple], processes: int, path: Path, keys: list[str]) -> None:
    """Run ``worker(*job)`` for each of ``jobs``, each in a process of its own (``processes`` at a
    time), printing each row it returns as it comes, then write the rows to the CSV ``path`` with the
    rows already there whose ``keys`` they do not have (a run of some logs or seeds keeps the
    others'), sorted by ``keys``, and print the table written."""
    rows = map_parallel(worker, jobs, processes, fresh_process=True, on_result=lambda _, row: print(row, flush=True))
    path.parent.mkdir(parents=True, exist_ok=True)
    table = with_rows_kept(pd.DataFrame(rows), path, keys)
    table.to_csv(path, index=False, float_format="%.4g")
    print(table.to_markdown(index=False, floatfmt=".3g"))


if __name__ == "__main__":
    main()
