"""FastSLAM on the default simulated maze run, 5 seeds: ATE and map error against ground truth.

For each seed: simulate the default run (random 4 x 4 maze, full exploration tour), then run
dead reckoning, FastSLAM 1.0 and FastSLAM 2.0 (100 particles, default settings). Prints one
Markdown table, rows per seed and estimator, and the means.
Run: ``python experiments/fastslam_default_maze.py`` (about a minute).

``--filter-seeds K`` runs each filter with K seeds of its own random draws (the table's rows
are then per seed and filter seed). ``--ideal`` measures the floor of this setting instead: a
noise-free laser, corners named from the truth (known association), a tight sensor model (each
corner's own covariance plus 0.5 mm and 0.1 degree) and 1000 particles; what error remains is the
drift of a map built from what the sensor can see, not noise or association.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import tempfile
from pathlib import Path

import pandas as pd

from mazeslam import log, sidecars, simulate
from mazeslam.evaluation.metrics import absolute_trajectory_error, align_se2, apply_se2, map_error
from mazeslam.filters.fastslam import FastSLAMParams
from mazeslam.filters.motion import dead_reckoning
from mazeslam.envs.simulator import SimulationConfig
from mazeslam.slam import SlamConfig, slam_on_file

SEEDS = range(5)
IDEAL_FILTER = dict(association="known", sigmaR=0.0005, sigmaB=math.radians(0.1),
                    NPARTICLES=1000)


def rows_for(seed: int, folder: Path, filter_seeds: int = 1, ideal: bool = False) -> list[dict]:
    config = SimulationConfig()
    if ideal:
        config = dataclasses.replace(config, laser=dataclasses.replace(config.laser, range_noise_std=0.0))
    run = simulate(folder / f"seed{seed}.log", config, seed=seed, progress=False)
    _, truth = sidecars.read_truth(run.truth_path)
    world = sidecars.read_map(run.map_path)
    rows = []
    reckoned = dead_reckoning(log.read(run.log_path), world["start_pose"])
    estimates = {("dead reckoning", 0): (reckoned, None)}
    for version in (1, 2):
        for filter_seed in range(filter_seeds):
            params = dataclasses.replace(FastSLAMParams(), version=version, seed=filter_seed,
                                         **(IDEAL_FILTER if ideal else {}))
            result = slam_on_file(run.log_path, SlamConfig(fastslam=params), progress=False)
            estimates[(f"FastSLAM {version}.0", filter_seed)] = (result.mean_poses, result.landmarks)
    for (name, filter_seed), (poses, landmarks) in estimates.items():
        row = {"seed": seed, "filter_seed": filter_seed, "estimator": name,
               "ate_rmse_m": absolute_trajectory_error(poses, truth)["rmse"],
               "aligned_ate_rmse_m": absolute_trajectory_error(poses, truth, align=True)["rmse"]}
        if landmarks is not None:
            row["map_rmse_m"] = map_error(landmarks, world["corners"])["rmse"]
            row["aligned_map_rmse_m"] = map_error(apply_se2(align_se2(poses, truth), landmarks), world["corners"])["rmse"]
        rows.append(row)
    return rows


def main(filter_seeds: int = 1, ideal: bool = False) -> pd.DataFrame:
    with tempfile.TemporaryDirectory() as folder:
        table = pd.DataFrame([row for seed in SEEDS for row in rows_for(seed, Path(folder), filter_seeds, ideal)])
    reckoning = table[table.estimator == "dead reckoning"].set_index("seed")
    for column in ("ate_rmse_m", "aligned_ate_rmse_m"):
        table[column.replace("_m", "_vs_reckoning")] = table[column] / table.seed.map(reckoning[column])
    return table


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--filter-seeds", type=int, default=1, help="filter seeds per simulated run")
    parser.add_argument("--ideal", action="store_true", help="noise-free laser, known association, 1000 particles")
    arguments = parser.parse_args()
    result = main(arguments.filter_seeds, arguments.ideal)
    print(result.to_markdown(index=False, floatfmt=".4f"))
    print()
    means = result.groupby("estimator").mean(numeric_only=True).drop(columns=["seed", "filter_seed"])
    print(means.to_markdown(floatfmt=".4f"))
