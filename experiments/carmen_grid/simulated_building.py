"""The grid filter's consistency where the truth is known: the simulated building of
``mazeslam.sim.building`` (a ring of 2 m corridors round a 16 x 10 m block, driven 1.3 times with
odometry that bends 0.02 rad per metre), one log per seed, run with configs/carmen.toml's ``[grid]``
settings (30 particles, its motion noise and thresholds), filter seed 0.

Per log: aligned ATE of the best particle's and of the weighted-mean path at the scans against the
true poses, dead reckoning's beside them; the mean path's pose NEES against the truth with the
covariance the filter states (3 degrees of freedom: consistent is a median near 2.4, a mean near 3,
95 % inside 7.81); the motion NIS over the processed scans (``mazeslam.gridslam.filter.motion_nis``:
the scan match's correction of the motion against the motion noise, consistent near 3); CPU seconds.

    python -m experiments.carmen_grid.simulated_building [--seeds 0 1 2 3 4] [--out FILE.csv]

Writes the CSV and, beside it, a Markdown table of the same name (quoted by docs/grid.md).
``--motion-noise`` replaces the config's ``[grid] motion_noise`` (``results/simulated_building_trimmed_noise.csv``:
the trimmed fit of results/motion_noise.md, 0.028 0.0086 0.0062). Run with
``PYTHONPATH`` set to a checkout of earlier code to measure that code the same way
(``results/simulated_building_before.csv``: commit 5651635, before the first motion was drawn with
noise and the motion noise measured; it reported no motion NIS).
"""

from __future__ import annotations

import argparse
import dataclasses
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

from mazeslam.core.motion import OdometryNoise, dead_reckoning
from mazeslam.data.log import read
from mazeslam.evaluation.consistency import nees_summary
from mazeslam.evaluation.metrics import absolute_trajectory_error, normalized_estimation_error
from mazeslam.gridslam import run_grid_slam
from mazeslam.pipeline import load_slam_config
from mazeslam.sim.building import simulate_building_log

HERE = Path(__file__).resolve().parent
CONFIG = HERE.parents[1] / "configs" / "carmen.toml"


def row_for(seed: int, motion_noise: OdometryNoise | None = None) -> dict:
    """One simulated building log (noise seed ``seed``) through the grid filter, scored against its
    truth; ``motion_noise`` in place of the config's ``[grid] motion_noise`` if given."""
    with tempfile.TemporaryDirectory() as folder:
        simulated = simulate_building_log(Path(folder) / "building.log", seed=seed)
        course_log = read(simulated.path)
    params = load_slam_config(CONFIG).grid_filter
    if motion_noise is not None:
        params = dataclasses.replace(params, motion_noise=motion_noise)
    began = time.process_time()
    result = run_grid_slam(course_log, simulated.geometry, simulated.start_pose, dataclasses.replace(params, seed=0))
    cpu_seconds = time.process_time() - began
    truth = simulated.truth[result.scan_records]
    reckoned = dead_reckoning(course_log, simulated.start_pose)[result.scan_records]
    nees = nees_summary(normalized_estimation_error(result.mean_poses, result.covariances, truth))
    return {
        "log_seed": seed,
        "scans": len(result.scan_records),
        "processed": int(result.processed.sum()),
        "ate_best_m": absolute_trajectory_error(result.best_poses, truth, align=True)["rmse"],
        "ate_mean_path_m": absolute_trajectory_error(result.mean_poses, truth, align=True)["rmse"],
        "dead_reckoning_ate_m": absolute_trajectory_error(reckoned, truth, align=True)["rmse"],
        "nees_mean": nees["mean"],
        "nees_median": nees["median"],
        "nees_inside_95": nees["inside_95"],
        **motion_nis_columns(result),
        "cpu_seconds": cpu_seconds,
    }


def motion_nis_columns(result) -> dict:
    """Mean and median motion NIS over the processed scans; NaN for code from before it was reported."""
    nis = getattr(result, "nis", np.full(1, np.nan))
    if not np.isfinite(nis).any():
        return {"nis_mean": np.nan, "nis_median": np.nan}
    return {"nis_mean": float(np.nanmean(nis)), "nis_median": float(np.nanmedian(nis))}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2, 3, 4])
    parser.add_argument("--out", type=Path, default=HERE / "results" / "simulated_building.csv")
    parser.add_argument(
        "--motion-noise",
        nargs=3,
        type=float,
        metavar=("SIGMAX", "SIGMATH", "SIGMATH_DRIVE"),
        help="the grid's motion noise instead of the config's",
    )
    args = parser.parse_args()
    noise = OdometryNoise(*args.motion_noise) if args.motion_noise else None
    rows = []
    for seed in args.seeds:
        rows.append(row_for(seed, noise))
        print(rows[-1], flush=True)
    table = pd.DataFrame(rows)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    table.to_csv(args.out, index=False, float_format="%.4g")
    args.out.with_suffix(".md").write_text(table.to_markdown(index=False, floatfmt=".3g") + "\n")
    print(table.to_markdown(index=False, floatfmt=".3g"))


if __name__ == "__main__":
    main()
