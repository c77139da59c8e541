"""The grid filter (mazeslam.grid) on the 8 CARMEN building logs: aligned ATE at the scans against
the logs' reference poses, the relation metric (Kümmerle et al. 2009, ``mazeslam.evaluation.relations``:
mean translational and rotational error over every pair of scans whose reference positions are within
``BUILDING_RADIUS`` = 3 m), wall-clock and CPU seconds against the log's duration, peak memory, and the best
particle's map (map_server YAML + PGM + PNG) beside each log's own picture. Consistency: the pose NEES
of the cloud's mean against the reference poses (with the covariance the filter states; the reference
is another SLAM estimate, not the truth, and its own errors count as the filter's here) and the motion NIS at the
processed scans (``mazeslam.grid.filter.motion_nis``: the scan match's correction against the motion
noise, needs no reference).

The filter's settings are configs/carmen.toml's ``[grid]`` (and ``[scan_matching]`` for the laser
odometry), as ``mazeslam slam LOG --config configs/carmen.toml`` runs them, with the seed replaced.

Run: ``python experiments/carmen_grid/run.py [--seeds 0 1 2 3 4] [--logs aces csail ...] [--jobs 2]``.
Each (log, seed) runs in its own process (one core each), so that its peak memory is its own.
Results: ``experiments/carmen_grid/results/table.csv`` and ``results/<log>_seed<k>/``. Memory: the
process's peak after importing and reading the log (``loaded_mb``; the log's text parsed into
floats dominates it for the large logs) and after the filter (``peak_mb``), and the most the
particles' maps held together (``map_mb``, shared tiles once).
"""

from __future__ import annotations

import argparse
import dataclasses
import resource
import tempfile
import time
from collections.abc import Callable
from multiprocessing import Pool
from pathlib import Path

import numpy as np
import pandas as pd

from mazeslam.evaluation.consistency import nees_summary
from mazeslam.evaluation.metrics import absolute_trajectory_error, normalized_estimation_error
from mazeslam.evaluation.relations import BUILDING_RADIUS, relation_metric, spatial_relations
from mazeslam.grid.map_io import grid_states, write_map
from mazeslam.grid_command import grid_on_run
from mazeslam.imports.carmen import import_carmen
from mazeslam.loaded_run import LoadedRun, load_run
from mazeslam.sidecars import write_trajectory
from mazeslam.slam import load_slam_config

CARMEN = Path(__file__).resolve().parents[3] / "shared" / "data" / "carmen"
CONFIG = Path(__file__).resolve().parents[2] / "configs" / "carmen.toml"
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


def run_one(job: tuple[str, int]) -> dict:
    """Import one log, run the grid filter with one seed, write its map and trajectory."""
    name, seed = job
    run = imported_run(name)
    loaded_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    began, began_cpu = time.perf_counter(), time.process_time()
    config = load_slam_config(CONFIG)
    result = grid_on_run(run, dataclasses.replace(config, grid=dataclasses.replace(config.grid, seed=seed)))
    seconds, cpu_seconds = time.perf_counter() - began, time.process_time() - began_cpu
    reference = run.truth[result.scan_records]
    ate = absolute_trajectory_error(result.best_poses, reference, align=True)
    nees = nees_summary(normalized_estimation_error(result.mean_poses, result.covariances, reference))
    out = RESULTS / f"{name}_seed{seed}"
    out.mkdir(parents=True, exist_ok=True)
    write_map(grid_states(result.grid), out)
    poses, covariances = result.record_trajectory()
    write_trajectory(out / "trajectory.csv", run.log.times, poses, covariances)
    return {
        "log": name,
        "seed": seed,
        "scans": len(result.scan_records),
        "processed": int(result.processed.sum()),
        "ate_rmse_m": ate["rmse"],
        "ate_max_m": ate["max"],
        "ate_mean_path_m": absolute_trajectory_error(result.mean_poses, reference, align=True)["rmse"],
        "nees_median": nees["median"],
        "nees_inside_95": nees["inside_95"],
        "nis_mean": float(np.nanmean(result.nis)),
        "nis_median": float(np.nanmedian(result.nis)),
        **relation_row(result.best_poses, reference),
        "seconds": seconds,
        "cpu_seconds": cpu_seconds,
        "log_seconds": run.log.duration,
        "resamplings": result.resamplings,
        "matched": float(np.nanmean(result.matched)),
        "map_mb": result.peak_map_bytes / 2**20,
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


def run_jobs(worker: Callable[[tuple], dict], jobs: list[tuple], processes: int, path: Path, keys: list[str]) -> None:
    """Run ``worker`` on each of ``jobs``, each in a process of its own (``processes`` at a time),
    printing each row it returns, then write the rows to the CSV ``path`` with the rows already
    there whose ``keys`` they do not have (a run of some logs or seeds keeps the others'), sorted by
    ``keys``, and print the table written."""
    with Pool(processes, maxtasksperchild=1) as pool:
        rows = []
        for row in pool.imap_unordered(worker, jobs):
            print(row, flush=True)
            rows.append(row)
    table = pd.DataFrame(rows)
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.exists():
        old = pd.read_csv(path)
        keep = ~old.set_index(keys).index.isin(table.set_index(keys).index)
        table = pd.concat([old[keep], table])
    table = table.sort_values(keys)
    table.to_csv(path, index=False, float_format="%.4g")
    print(table.to_markdown(index=False, floatfmt=".3g"))


if __name__ == "__main__":
    main()
