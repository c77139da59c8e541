"""Consistency of FastSLAM on simulated default mazes: ATE, pose NEES, NIS and resampling over
seeds, particle counts and both versions.

    python -m experiments.consistency.run                   # seeds 11-20, 10/100/1000 particles, 1.0 and 2.0
    python -m experiments.consistency.run --seeds 31 32 --particles 100 --versions 2

Writes ``results.csv`` (one row per run) and ``summary.md`` (per setting: medians and worst seeds)
beside this script, and ``nees_over_time.png`` (NEES along one run per version).
"""

from __future__ import annotations

import argparse
import dataclasses
import tempfile
from pathlib import Path

import pandas as pd

from mazeslam import simulate
from mazeslam.data.loaded_run import load_run
from mazeslam.evaluation.consistency import POSE_BOUND_95, nis_summary
from mazeslam.evaluation.scoring import DEAD_RECKONING, score_run
from mazeslam.pipeline import SlamConfig, run_slam
from mazeslam.sweeps.pool import map_parallel

HERE = Path(__file__).resolve().parent


def one_log(seed: int, particles: list[int], versions: list[int], changes: dict) -> list[dict]:
    """Simulate the default maze with ``seed``, run every filter setting on it (``changes`` to
    ``[fastslam]`` applied), score each."""
    with tempfile.TemporaryDirectory() as folder:
        run = load_run(simulate(Path(folder) / "run.log", seed=seed, progress=False).log_path)
    rows = []
    for version in versions:
        for count in particles:
            config = SlamConfig()
            config = dataclasses.replace(
                config,
                fastslam=dataclasses.replace(config.fastslam, NPARTICLES=count, version=version, seed=seed, **changes),
            )
            result = run_slam(run, config, progress=False)
            score = score_run(run, result)
            nis = nis_summary(result.nis)
            rows.append(
                {
                    "seed": seed,
                    "version": version,
                    "particles": count,
                    "ate_m": score.ate(),
                    "reckoning_ate_m": score.ate(DEAD_RECKONING),
                    "ate_ratio": score.ate() / score.ate(DEAD_RECKONING),
                    "aligned_ate_m": score.ate(aligned=True),
                    "median_nees": score.table.loc[score.mean_row, "median_nees"],
                    "nees_inside_95": score.nees_summary["inside_95"],
                    "nis_mean": nis["mean"],
                    "resampled_fraction": result.resampled_fraction,
                    "landmarks": len(result.landmarks),
                    "nees": score.nees,
                }
            )
    return rows


def summary(table: pd.DataFrame) -> str:
    """Per version and particle count: medians over seeds and the worst seed of each check."""
    grouped = table.groupby(["version", "particles"])
    shown = pd.DataFrame(
        {
            "seeds": grouped.size(),
            "ATE median [mm]": grouped["ate_m"].median() * 1000,
            "ATE worst [mm]": grouped["ate_m"].max() * 1000,
            "ATE/DR worst": grouped["ate_ratio"].max(),
            "NEES median of medians": grouped["median_nees"].median(),
            "NEES worst median": grouped["median_nees"].max(),
            "NIS mean": grouped["nis_mean"].mean(),
            "resampled worst": grouped["resampled_fraction"].max(),
        }
    )
    return (
        "Simulated default mazes, default settings but the particle count and version. NEES: median over a "
        f"run's records (consistent: about 2.4, 95 % bound {POSE_BOUND_95:.2f}); NIS: mean over associated "
        "observations (consistent: 2); resampled: share of scans.\n\n" + shown.to_markdown(floatfmt=".3g") + "\n"
    )


def plot_nees(table: pd.DataFrame, path: Path) -> None:
    """NEES along the run, one seed, both versions at the largest particle count."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    seed, count = table["seed"].min(), table["particles"].max()
    fig, ax = plt.subplots(figsize=(8, 4))
    for _, row in table[(table["seed"] == seed) & (table["particles"] == count)].iterrows():
        ax.semilogy(row["nees"], linewidth=0.8, label=f"FastSLAM {row['version']}.0, {count} particles")
    ax.axhline(POSE_BOUND_95, color="black", linestyle="--", linewidth=0.8, label="95 % bound (3 dof)")
    ax.axhline(3.0, color="0.5", linestyle=":", linewidth=0.8, label="consistent mean (3)")
    ax.set_xlabel("log record")
    ax.set_ylabel("pose NEES (log scale)")
    ax.set_title(f"Pose NEES along the run: simulated default maze, seed {seed}")
    ax.legend(loc="upper left", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=list(range(11, 21)))
    parser.add_argument("--particles", type=int, nargs="+", default=[10, 100, 1000])
    parser.add_argument("--versions", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", type=Path, default=HERE)
    parser.add_argument(
        "--set",
        nargs="*",
        default=[],
        metavar="NAME=VALUE",
        help="[fastslam] settings to change, e.g. sigmaX=0.003 (studies; committed tables use none)",
    )
    arguments = parser.parse_args()
    changes = {name: float(value) for name, value in (item.split("=") for item in arguments.set)}
    calls = [(seed, arguments.particles, arguments.versions, changes) for seed in arguments.seeds]
    table = pd.DataFrame([row for rows in map_parallel(one_log, calls, arguments.workers) for row in rows])
    arguments.out.mkdir(parents=True, exist_ok=True)
    table.drop(columns="nees").to_csv(arguments.out / "results.csv", index=False, float_format="%.6g")
    text = summary(table)
    (arguments.out / "summary.md").write_text(text)
    plot_nees(table, arguments.out / "nees_over_time.png")
    print(text)


if __name__ == "__main__":
    main()
