"""FastSLAM on the default simulated maze run, 5 seeds: ATE and map error against ground truth.

For each seed: simulate the default run (random 4 x 4 maze, full exploration tour), then run
dead reckoning, FastSLAM 1.0 and FastSLAM 2.0 (100 particles, default settings). Prints one
Markdown table, rows per seed and estimator, and the means.
Run: ``python experiments/fastslam_default_maze.py`` (about a minute).
"""

from __future__ import annotations

import dataclasses
import tempfile
from pathlib import Path

import pandas as pd

from mazeslam import log, sidecars, simulate
from mazeslam.evaluation.metrics import absolute_trajectory_error, align_se2, apply_se2, map_error
from mazeslam.filters.fastslam import FastSLAMParams
from mazeslam.filters.motion import dead_reckoning
from mazeslam.slam import SlamConfig, slam_on_file

SEEDS = range(5)


def rows_for(seed: int, folder: Path) -> list[dict]:
    run = simulate(folder / f"seed{seed}.log", seed=seed, progress=False)
    _, truth = sidecars.read_truth(run.truth_path)
    world = sidecars.read_map(run.map_path)
    rows = []
    reckoned = dead_reckoning(log.read(run.log_path), world["start_pose"])
    estimates = {"dead reckoning": (reckoned, None)}
    for version in (1, 2):
        config = SlamConfig(fastslam=dataclasses.replace(FastSLAMParams(), version=version))
        result = slam_on_file(run.log_path, config, progress=False)
        estimates[f"FastSLAM {version}.0"] = (result.mean_poses, result.landmarks)
    for name, (poses, landmarks) in estimates.items():
        row = {"seed": seed, "estimator": name,
               "ate_rmse_m": absolute_trajectory_error(poses, truth)["rmse"],
               "aligned_ate_rmse_m": absolute_trajectory_error(poses, truth, align=True)["rmse"]}
        if landmarks is not None:
            row["map_rmse_m"] = map_error(landmarks, world["corners"])["rmse"]
            row["aligned_map_rmse_m"] = map_error(apply_se2(align_se2(poses, truth), landmarks), world["corners"])["rmse"]
        rows.append(row)
    return rows


def main() -> pd.DataFrame:
    with tempfile.TemporaryDirectory() as folder:
        table = pd.DataFrame([row for seed in SEEDS for row in rows_for(seed, Path(folder))])
    reckoning = table[table.estimator == "dead reckoning"].set_index("seed")
    for column in ("ate_rmse_m", "aligned_ate_rmse_m"):
        table[column.replace("_m", "_vs_reckoning")] = table[column] / table.seed.map(reckoning[column])
    return table


if __name__ == "__main__":
    result = main()
    print(result.to_markdown(index=False, floatfmt=".4f"))
    print()
    print(result.groupby("estimator").mean(numeric_only=True).drop(columns="seed").to_markdown(floatfmt=".4f"))
