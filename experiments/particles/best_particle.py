"""Why the map gets worse with more particles: the map is the best-weighted particle's, and that
particle's own path is farther from the truth than the cloud's mean.

    python -m experiments.particles.best_particle     (seeds 0 and 1, 100 and 1000 particles; ~1 min)

Writes best_particle.md beside this file: per seed and particle count, the ATE of the mean path and
of the best particle's path (as estimated and aligned, mm), and the aligned map error (mm), as in the
particles sweep.
"""

from __future__ import annotations

import argparse
import dataclasses
import tempfile
from pathlib import Path

import pandas as pd

from mazeslam import simulate
from mazeslam.data.loaded_run import load_run
from mazeslam.evaluation.scoring import score_run
from mazeslam.pipeline import SlamConfig, run_slam

HERE = Path(__file__).resolve().parent


def main(seeds=(0, 1), counts=(100, 1000)) -> pd.DataFrame:
    rows = []
    for seed in seeds:
        with tempfile.TemporaryDirectory() as folder:
            run = load_run(simulate(Path(folder) / "run.log", seed=seed, progress=False).log_path)
        for count in counts:
            config = SlamConfig()
            config = dataclasses.replace(
                config, fastslam=dataclasses.replace(config.fastslam, NPARTICLES=count, seed=seed)
            )
            score = score_run(run, run_slam(run, config, progress=False))
            rows.append(
                {
                    "seed": seed,
                    "particles": count,
                    "mean path ATE [mm]": 1000 * score.ate(),
                    "mean path ATE aligned [mm]": 1000 * score.ate(aligned=True),
                    "best particle ATE [mm]": 1000 * score.ate(score.best_row),
                    "best particle ATE aligned [mm]": 1000 * score.ate(score.best_row, aligned=True),
                    "map aligned [mm]": 1000 * score.map_errors["aligned"]["rmse"],
                    "median NEES": score.nees_summary["median"],
                }
            )
    return pd.DataFrame(rows)


if __name__ == "__main__":
    # No options; --help says what the script does (it rewrites its committed results).
    argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter).parse_args()
    table = main()
    table[["seed", "particles"]] = table[["seed", "particles"]].astype(str)
    text = (
        "Default settings (FastSLAM 2.0), default maze runs; the map is the best-weighted particle's "
        "(`python -m experiments.particles.best_particle`).\n\n" + table.to_markdown(index=False, floatfmt=".2f") + "\n"
    )
    (HERE / "best_particle.md").write_text(text)
    print(text)
