"""FastSLAM beside the batch optimum on simulated default logs: writes results.csv and results.md here.

    python -m experiments.smoother.run [--seeds 404 505 606 707 808] [--config FILE] [--workers 2]

Per seed: simulate the default maze run, then score against its truth (ATE RMSE at every record, as
estimated and after the best rigid alignment; NEES of the pose): dead reckoning, FastSLAM (seeded
like the simulation) in the variants of ``FILTERS``, the batch optimum with known association
(``mazeslam smooth``'s) and the batch optimum with the association of the default filter's (FastSLAM
2.0, 100 particles) final map
(``--association from-run``'s). Every estimator uses the slam config's noise (the defaults without
``--config``): rerun after the filter's defaults change. results.md names the commit it was made on.
"""

from __future__ import annotations

import argparse
import dataclasses
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

from mazeslam.core.config import with_changes
from mazeslam.data.loaded_run import load_run
from mazeslam.evaluation.consistency import nees_summary
from mazeslam.evaluation.metrics import normalized_estimation_error
from mazeslam.evaluation.scoring import (
    DEAD_RECKONING,
    error_table,
    score_run,
)
from mazeslam.pipeline import SlamConfig, load_slam_config, run_slam
from mazeslam.sim.simulator import simulate
from mazeslam.smoothing.optimum import Smoothed, known_optimum, map_identities, smooth_run
from mazeslam.sweeps.pool import map_parallel

HERE = Path(__file__).resolve().parent
SEEDS = [404, 505, 606, 707, 808]
#: FastSLAM variants: name -> [fastslam] changes.
FILTERS = {
    "FastSLAM 1.0, 100 particles": {"NPARTICLES": 100, "version": 1},
    "FastSLAM 1.0, 1000 particles": {"NPARTICLES": 1000, "version": 1},
    "FastSLAM 2.0, 100 particles": {"NPARTICLES": 100, "version": 2},
    "FastSLAM 2.0, 1000 particles": {"NPARTICLES": 1000, "version": 2},
    "FastSLAM 1.0, 100 particles, known association": {"NPARTICLES": 100, "version": 1, "association": "known"},
}
OPTIMUM = "batch optimum (known association)"
#: The filter whose final map names the corners for the second optimum (``mazeslam smooth --association from-run``).
ASSOCIATION_FROM = "FastSLAM 2.0, 100 particles"  # the default filter
OPTIMUM_FROM_RUN = f"batch optimum (association of {ASSOCIATION_FROM})"


def seed_rows(seed: int, config: SlamConfig) -> list[dict]:
    """One row per estimator on the default run of ``seed``: ATE RMSE (m), NEES, chi2/dof, seconds."""
    with tempfile.TemporaryDirectory() as folder:
        run = load_run(simulate(Path(folder) / "run.log", seed=seed, progress=False).log_path, config.sensor)
    radius = config.evaluation.match_radius
    rows = []
    for name, changes in FILTERS.items():
        filter_config = dataclasses.replace(config, fastslam=with_changes(config.fastslam, seed=seed, **changes))
        started = time.perf_counter()
        result = run_slam(run, filter_config, progress=False)
        seconds = time.perf_counter() - started
        score = score_run(run, result, radius)
        if name == ASSOCIATION_FROM:
            rows.append(_row(seed, DEAD_RECKONING, score.table.loc[DEAD_RECKONING]))
            from_run = smooth_run(run, config, map_identities(run, result.mean_poses, result.landmarks, radius))
        rows.append(_row(seed, name, score.table.loc[score.mean_row], score.nees_summary, seconds=seconds))
    for name, smoothed in ((OPTIMUM, known_optimum(run, config)), (OPTIMUM_FROM_RUN, from_run)):
        rows.append(_optimum_row(seed, name, smoothed, run.truth, score.records))
    return rows


def _optimum_row(seed: int, name: str, smoothed: Smoothed, truth: np.ndarray, records: np.ndarray) -> dict:
    result = smoothed.result
    table = error_table({name: smoothed.poses[records]}, truth[records])
    nees = nees_summary(normalized_estimation_error(result.poses, result.pose_covariances, truth[result.scan_records]))
    return _row(seed, name, table.loc[name], nees, result.chi2_per_dof, smoothed.seconds)


def _row(
    seed: int,
    name: str,
    errors: pd.Series,
    nees: dict | None = None,
    chi2_per_dof: float = np.nan,
    seconds: float = np.nan,
) -> dict:
    nees = nees or {}
    return {
        "seed": seed,
        "estimator": name,
        "ate_rmse": errors["ate_rmse"],
        "ate_aligned_rmse": errors["aligned_rmse"],
        "nees_mean": nees.get("mean"),
        "nees_median": nees.get("median"),
        "chi2_per_dof": chi2_per_dof,
        "seconds": seconds,
    }


def summary_markdown(table: pd.DataFrame, commit: str, config_path) -> str:
    """Mean over the seeds per estimator (min-max in brackets for the ATE), and each one's ratio to the
    known-association optimum (mean of the per-seed ratios)."""
    table = pd.concat([table[table.estimator == DEAD_RECKONING], table[table.estimator != DEAD_RECKONING]])
    optimum = table[table.estimator == OPTIMUM].set_index("seed")
    table = table.assign(
        ratio=table.ate_rmse / table.seed.map(optimum.ate_rmse),
        aligned_ratio=table.ate_aligned_rmse / table.seed.map(optimum.ate_aligned_rmse),
    )
    lines = [
        f"| {name} | {_spread(group.ate_rmse)} | {_spread(group.ate_aligned_rmse)} | {_mean(group.ratio)} "
        f"| {_mean(group.aligned_ratio)} | {_mean(group.nees_median, 1)} | {_mean(group.chi2_per_dof)} "
        f"| {_mean(group.seconds)} |"
        for name, group in table.groupby("estimator", sort=False)
    ]
    seeds = ", ".join(str(s) for s in sorted(table.seed.unique()))
    return (
        f"Produced by `experiments/smoother/run.py` on commit {commit} with "
        f"{'the default slam settings' if config_path is None else config_path}, seeds {seeds} (default "
        "simulated maze run each). ATE RMSE at every record in mm, mean over the seeds (min-max); ratio: to the "
        "known-association optimum on the same seed, mean of the per-seed ratios; NEES: median over the records "
        "(FastSLAM: every record, with the particle cloud's covariance; optimum: the scans, with the covariance "
        "from its information matrix), mean over the seeds; chi2/dof of the optimum's residuals; seconds: "
        "FastSLAM's filtering, or the optimum's corner extraction and solving.\n\n"
        "| estimator | ATE [mm] | ATE aligned [mm] | ratio | ratio aligned | NEES median | chi2/dof | seconds |\n"
        "|:--|--:|--:|--:|--:|--:|--:|--:|\n" + "\n".join(lines) + "\n"
    )


def _spread(metres: pd.Series) -> str:
    """Mean (min-max) in mm."""
    return f"{1000 * metres.mean():.1f} ({1000 * metres.min():.1f}-{1000 * metres.max():.1f})"


def _mean(values: pd.Series, digits: int = 2) -> str:
    """Mean of the defined values, empty if none."""
    values = values.dropna()
    return f"{values.mean():.{digits}f}" if len(values) else ""


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=SEEDS)
    parser.add_argument("--config", help="slam TOML (default: the built-in defaults)")
    parser.add_argument("--workers", type=int, default=2, help="processes, one seed each")
    arguments = parser.parse_args()
    config = load_slam_config(arguments.config)
    calls = [(seed, config) for seed in arguments.seeds]
    rows = [row for rows in map_parallel(seed_rows, calls, arguments.workers) for row in rows]
    table = pd.DataFrame(rows)
    table.to_csv(HERE / "results.csv", index=False)
    commit = subprocess.run(
        ["git", "describe", "--always", "--dirty"], capture_output=True, text=True, cwd=HERE, check=True
    ).stdout.strip()
    text = summary_markdown(table, commit, arguments.config)
    (HERE / "results.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
