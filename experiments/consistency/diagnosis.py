"""Where FastSLAM's stated uncertainty departs from its error, on simulated default mazes.

    python -m experiments.consistency.diagnosis            # seeds 11-20

For each seed and setting: NIS per observation kind (is each part of the observation model
right?), pose NEES split into position (2 dof, consistent median 1.39) and heading (1 dof,
consistent median 0.45), and how far the particles' final maps disagree in orientation
(``map_orientation_spread``) beside the final heading error: a cloud whose maps all share one
orientation can no longer state how far the whole map is turned in the world. Writes
``diagnosis.csv`` and ``diagnosis.md`` beside this script.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

from mazeslam import simulate
from mazeslam.core.geometry import wrap_angle
from mazeslam.data.loaded_run import load_run
from mazeslam.evaluation.consistency import map_orientation_spread
from mazeslam.evaluation.metrics import normalized_estimation_error
from mazeslam.fastslam.filter import FastSLAMParams
from mazeslam.pipeline import SlamConfig, run_slam
from mazeslam.sweeps.pool import map_parallel

HERE = Path(__file__).resolve().parent
#: (particles, likelihood_exponent): the default, the default without the consistency margin, 1000 particles.
SETTINGS = [
    (100, FastSLAMParams.likelihood_exponent),
    (100, 1.0),
    (1000, FastSLAMParams.likelihood_exponent),
]


def block_nees(errors: np.ndarray, covariances: np.ndarray, axes: list[int]) -> np.ndarray:
    """(R,) NEES of the ``axes`` components of ``errors`` (R, 3) under that block of ``covariances`` (R, 3, 3)
    (the position or the heading alone; the whole pose is ``metrics.normalized_estimation_error``)."""
    e = errors[:, axes]
    block = covariances[:, axes][:, :, axes]
    return np.einsum("ri,rij,rj->r", e, np.linalg.pinv(block), e)


def one_seed(seed: int) -> list[dict]:
    """Every setting of ``SETTINGS`` on the default maze of ``seed``."""
    with tempfile.TemporaryDirectory() as folder:
        run = load_run(simulate(Path(folder) / "run.log", seed=seed, progress=False).log_path)
    assert run.truth is not None
    rows = []
    for particles, exponent in SETTINGS:
        config = SlamConfig()
        config = dataclasses.replace(
            config,
            fastslam=dataclasses.replace(
                config.fastslam, NPARTICLES=particles, likelihood_exponent=exponent, seed=seed
            ),
        )
        result = run_slam(run, config, progress=False)
        errors = result.mean_poses - run.truth
        errors[:, 2] = wrap_angle(errors[:, 2])
        moved = slice(1, None)  # the first record: the start pose, known exactly
        groups = result.nis_by_kind()
        slam = result.filter
        rows.append(
            {
                "seed": seed,
                "particles": particles,
                "likelihood_exponent": exponent,
                "nis_mean": float(result.nis.mean()),
                **{
                    f"nis_{kind}": float(groups[kind].mean()) if kind in groups else None
                    for kind in ("corner", "wall_end")
                },
                "nees_median": float(
                    np.median(normalized_estimation_error(result.mean_poses, result.pose_covariances, run.truth)[moved])
                ),
                "position_nees_median": float(np.median(block_nees(errors, result.pose_covariances, [0, 1])[moved])),
                "heading_nees_median": float(np.median(block_nees(errors, result.pose_covariances, [2])[moved])),
                "map_orientation_spread_deg": math.degrees(
                    map_orientation_spread(slam.means, slam.exists, slam.weights())
                ),
                "final_heading_error_deg": math.degrees(abs(errors[-1, 2])),
                "resampled_fraction": result.resampled_fraction,
            }
        )
    return rows


def summary(table: pd.DataFrame) -> str:
    grouped = table.groupby(["particles", "likelihood_exponent"])
    shown = pd.DataFrame(
        {
            "NIS corner": grouped["nis_corner"].mean(),
            "NIS wall end": grouped["nis_wall_end"].mean(),
            "NIS all": grouped["nis_mean"].mean(),
            "NEES median (worst seed)": grouped["nees_median"].max(),
            "position NEES median (worst)": grouped["position_nees_median"].max(),
            "heading NEES median (worst)": grouped["heading_nees_median"].max(),
            "map orientation spread [deg], median": grouped["map_orientation_spread_deg"].median(),
            "final heading error [deg], median": grouped["final_heading_error_deg"].median(),
            "resampled, worst": grouped["resampled_fraction"].max(),
        }
    )
    return (
        f"Simulated default mazes, seeds {table['seed'].min()}-{table['seed'].max()}, FastSLAM 2.0 "
        "defaults but the particle count and the consistency margin (`likelihood_exponent`; 1: none). "
        "NIS: mean over the associated observations of each kind (consistent: 2). NEES medians over a "
        "run's records (consistent: 3 for the pose, 1.39 for the position, 0.45 for the heading), worst "
        "over seeds. Map orientation spread: how far the particles' final maps are turned against each "
        "other (`map_orientation_spread`), beside how far the estimate's heading is off at the end. "
        "`python -m experiments.consistency.diagnosis`.\n\n" + shown.to_markdown(floatfmt=".3g") + "\n"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=list(range(11, 21)))
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", type=Path, default=HERE)
    arguments = parser.parse_args()
    calls = [(seed,) for seed in arguments.seeds]
    table = pd.DataFrame([row for rows in map_parallel(one_seed, calls, arguments.workers) for row in rows])
    arguments.out.mkdir(parents=True, exist_ok=True)
    table.to_csv(arguments.out / "diagnosis.csv", index=False, float_format="%.6g")
    text = summary(table)
    (arguments.out / "diagnosis.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
