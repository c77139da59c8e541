"""FastSLAM on the default simulated maze run, 5 seeds: ATE, map error, NEES, NIS and the ratio to
the batch optimum against the simulator's truth.

For each seed: simulate the default run (random 4 x 4 maze, full exploration tour), then run
FastSLAM 1.0 and FastSLAM 2.0 (100 particles, default settings otherwise: FastSLAM 2.0 is the
default) and score each as ``mazeslam slam`` does (dead reckoning beside it; the optimum: the batch
least-squares solution with the filter's noise model and the true association). Writes
``results.md`` (per seed and means) and ``results.csv`` beside this script, and the default
filter's figure of seed 0 to ``docs/img/fastslam_default_maze.png``.
Run: ``python -m experiments.fastslam_default_maze.run`` (about a minute).

``--filter-seeds K`` runs each filter with K seeds of its own random draws (the table's rows
are then per seed and filter seed). ``--ideal`` measures the floor of this setting instead: a
noise-free laser, corners named from the truth (known association), a tight sensor model (each
corner's own covariance plus 0.5 mm and 0.1 degree) and 1000 particles; what error remains is the
drift of a map built from what the sensor can see, not noise or association. Both variants print
their tables and write ``results_<variant>.md`` and ``.csv``, no figure.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import tempfile
from pathlib import Path

import pandas as pd

from mazeslam import simulate
from mazeslam.data.loaded_run import load_run
from mazeslam.data.scans import scan_points_world
from mazeslam.evaluation.consistency import nis_summary
from mazeslam.evaluation.scoring import DEAD_RECKONING, score_run
from mazeslam.fastslam.filter import FastSLAMParams
from mazeslam.pipeline import SlamConfig, run_slam
from mazeslam.sim.simulator import SimulationConfig
from mazeslam.smoothing.optimum import optimum_columns
from mazeslam.viz import slam_figure as slam_report

HERE = Path(__file__).resolve().parent
FIGURE = HERE.parents[1] / "docs" / "img" / "fastslam_default_maze.png"
SEEDS = range(5)
IDEAL_FILTER = dict(association="known", sigmaR=0.0005, sigmaB=math.radians(0.1), NPARTICLES=1000)


def rows_for(seed: int, folder: Path, filter_seeds: int = 1, ideal: bool = False, figure: bool = False) -> list[dict]:
    config = SimulationConfig()
    if ideal:
        config = dataclasses.replace(config, laser=dataclasses.replace(config.laser, range_noise_std=0.0))
    run = load_run(simulate(folder / f"seed{seed}.log", config, seed=seed, progress=False).log_path)
    rows = []
    for version in (1, 2):
        for filter_seed in range(filter_seeds):
            params = dataclasses.replace(
                FastSLAMParams(), version=version, seed=filter_seed, **(IDEAL_FILTER if ideal else {})
            )
            slam_config = SlamConfig(fastslam=params)
            result = run_slam(run, slam_config, progress=False)
            score = score_run(run, result, slam_config.evaluation.match_radius)
            if not rows:
                rows.append(
                    {
                        "seed": seed,
                        "filter_seed": 0,
                        "estimator": "dead reckoning",
                        "ate_rmse_m": score.ate(DEAD_RECKONING),
                        "aligned_ate_rmse_m": score.ate(DEAD_RECKONING, aligned=True),
                    }
                )
            optimum = optimum_columns(run, slam_config, score) or {}
            rows.append(
                {
                    "seed": seed,
                    "filter_seed": filter_seed,
                    "estimator": f"FastSLAM {version}.0",
                    "ate_rmse_m": score.ate(),
                    "aligned_ate_rmse_m": score.ate(aligned=True),
                    "map_rmse_m": score.map_errors["as estimated"]["rmse"],
                    "aligned_map_rmse_m": score.map_errors["aligned"]["rmse"],
                    "optimum_ate_rmse_m": optimum.get("optimum_ate_rmse"),
                    "optimum_ratio": optimum.get("optimum_ratio"),
                    "optimum_aligned_ratio": optimum.get("optimum_aligned_ratio"),
                    "median_nees": score.nees_summary["median"],
                    "nees_inside_95": score.nees_summary["inside_95"],
                    "nis_mean": nis_summary(result.nis)["mean"],
                    "resampled_fraction": result.resampled_fraction,
                }
            )
            if figure and seed == 0 and filter_seed == 0 and version == FastSLAMParams().version:
                points = scan_points_world(
                    run.log,
                    result.mean_poses,
                    run.geometry,
                    slam_config.corners.min_range,
                    slam_config.corners.max_range,
                )
                slam_report.plot_slam(
                    FIGURE,
                    result,
                    points,
                    run.truth,
                    run.walls,
                    title=f"Default maze, seed 0: FastSLAM {version}.0 (default), {params.NPARTICLES} particles",
                    true_landmarks=run.true_corners,
                )
    return rows


def main(filter_seeds: int = 1, ideal: bool = False, figure: bool = False) -> pd.DataFrame:
    with tempfile.TemporaryDirectory() as folder:
        table = pd.DataFrame(
            [row for seed in SEEDS for row in rows_for(seed, Path(folder), filter_seeds, ideal, figure)]
        )
    reckoning = table[table.estimator == "dead reckoning"].set_index("seed")
    for column in ("ate_rmse_m", "aligned_ate_rmse_m"):
        table[column.replace("_m", "_vs_reckoning")] = table[column] / table.seed.map(reckoning[column])
    return table


def markdown(table: pd.DataFrame) -> str:
    means = table.groupby("estimator").mean(numeric_only=True).drop(columns=["seed", "filter_seed"])
    spread = table.groupby("estimator")[["ate_rmse_vs_reckoning"]].agg(["min", "max"])
    means["ate_vs_reckoning_min"] = spread[("ate_rmse_vs_reckoning", "min")]
    means["ate_vs_reckoning_max"] = spread[("ate_rmse_vs_reckoning", "max")]
    means["runs_within_a_third"] = table.groupby("estimator").ate_rmse_vs_reckoning.apply(lambda r: (r <= 1 / 3).mean())
    return (
        "Default simulated maze runs, seeds 0-4, 100 particles, default settings (`python -m "
        "experiments.fastslam_default_maze.run`; `--filter-seeds K`: K filter seeds per maze; `--ideal`: "
        "noise-free laser, known association, 1000 particles). Lengths in metres; NEES: median over the "
        "run's records (consistent: 3); NIS: mean over associated observations (consistent: 2); optimum ratio: the "
        "filter's ATE over the batch optimum's (1: as good as any estimator).\n\n## Per seed\n\n"
        + table.to_markdown(index=False, floatfmt=".4g")
        + "\n\n## Means over seeds\n\n"
        + means.to_markdown(floatfmt=".4g")
        + "\n"
    )


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--filter-seeds", type=int, default=1, help="filter seeds per simulated run")
    parser.add_argument("--ideal", action="store_true", help="noise-free laser, known association, 1000 particles")
    parser.add_argument("--tables-only", action="store_true", help="rewrite the .md from the .csv without running")
    arguments = parser.parse_args()
    plain = arguments.filter_seeds == 1 and not arguments.ideal
    variant = "" if plain else "_ideal" if arguments.ideal else f"_filter_seeds{arguments.filter_seeds}"
    if arguments.tables_only:
        result = pd.read_csv(HERE / f"results{variant}.csv")
    else:
        result = main(arguments.filter_seeds, arguments.ideal, figure=plain)
        result.to_csv(HERE / f"results{variant}.csv", index=False)
    text = markdown(result)
    print(text)
    (HERE / f"results{variant}.md").write_text(text)
