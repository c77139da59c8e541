"""orebro (no odometry) with its own laser odometry's fitted noise as the grid filter's motion noise,
against the default ``blind_motion_noise``: why the default is kept for logs without odometry.

orebro's fit (``results/motion_noise.csv``, its row) replaces ``[grid] blind_motion_noise``; all else
is configs/carmen.toml's, as run.py runs it. The default's rows for the same seeds are run.py's
(``results/table.csv``).

    python experiments/carmen_grid/blind_noise_trial.py [--seeds 0 1]

Writes ``results/blind_noise_trial.csv``: per seed the aligned ATE of the best path against the
reference poses, the mean path's pose NEES median and the motion NIS median, with each noise.
"""

from __future__ import annotations

import argparse
import dataclasses
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
from run import CARMEN, CONFIG, RESULTS  # this folder's run.py

from mazeslam.evaluation.consistency import nees_summary
from mazeslam.evaluation.metrics import absolute_trajectory_error, normalized_estimation_error
from mazeslam.filters.motion import OdometryNoise
from mazeslam.grid_command import grid_on_run
from mazeslam.imports.carmen import import_carmen
from mazeslam.loaded_run import load_run
from mazeslam.slam import load_slam_config

LOG = "orebro"


def orebro_fit() -> OdometryNoise:
    """orebro's fitted laser-odometry noise, from motion_noise.py's table."""
    row = pd.read_csv(RESULTS / "motion_noise.csv").set_index("log").loc[LOG]
    return OdometryNoise(float(row.sigmaX), float(row.sigmaTH), float(row.sigmaTH_drive))


def trial_row(seed: int, noise: OdometryNoise) -> dict:
    """One filter seed on orebro with ``noise`` as the blind motion noise."""
    with tempfile.TemporaryDirectory() as folder:
        course = Path(folder) / f"{LOG}.log"
        import_carmen(CARMEN / f"{LOG}-corrected.log.gz", course)
        run = load_run(course)
    config = load_slam_config(CONFIG)
    grid = dataclasses.replace(config.grid, seed=seed, blind_motion_noise=noise)
    result = grid_on_run(run, dataclasses.replace(config, grid=grid))
    reference = run.truth[result.scan_records]
    nees = normalized_estimation_error(result.mean_poses, result.covariances, reference)
    return {
        "log": LOG,
        "seed": seed,
        "blind_motion_noise": f"{noise.sigmaX:.4g} {noise.sigmaTH:.4g} {noise.sigmaTH_drive:.4g}",
        "ate_rmse_m": absolute_trajectory_error(result.best_poses, reference, align=True)["rmse"],
        "nees_median": nees_summary(nees)["median"],
        "nis_median": float(np.nanmedian(result.nis)),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", nargs="+", type=int, default=[0, 1])
    args = parser.parse_args()
    fit = orebro_fit()
    rows = []
    for seed in args.seeds:
        rows.append(trial_row(seed, fit))
        print(rows[-1], flush=True)
    table = pd.DataFrame(rows)
    table.to_csv(RESULTS / "blind_noise_trial.csv", index=False, float_format="%.4g")
    print(table.to_markdown(index=False, floatfmt=".3g"))


if __name__ == "__main__":
    main()
