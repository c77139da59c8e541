"""Why the map gets worse with more particles: the map is the best-weighted particle's, and that
particle's own path is farther from the truth than the cloud's mean.

    python experiments/particles/best_particle.py     (seeds 0 and 1, 100 and 1000 particles; ~1 min)

Writes best_particle.md beside this file: per seed and particle count, the ATE of the mean path and
of the best particle's path (as estimated and aligned, mm), and the aligned map error (mm), as in the
particles sweep.
"""

from __future__ import annotations

import dataclasses
import tempfile
from pathlib import Path

import pandas as pd

from mazeslam import simulate
from mazeslam.evaluation.scoring import FILTER_MEAN, score_run
from mazeslam.loaded_run import load_run
from mazeslam.slam import SlamConfig, slam_on_run

HERE = Path(__file__).resolve().parent
BEST = "FastSLAM (best particle)"


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
            score = score_run(run, slam_on_run(run, config, progress=False))
            rows.append(
                {
                    "seed": seed,
                    "particles": count,
                    "mean path ATE [mm]": 1000 * score.ate(FILTER_MEAN),
                    "mean path ATE aligned [mm]": 1000 * score.ate(FILTER_MEAN, aligned=True),
                    "best particle ATE [mm]": 1000 * score.ate(BEST),
                    "best particle ATE aligned [mm]": 1000 * score.ate(BEST, aligned=True),
                    "map aligned [mm]": 1000 * score.map_errors["aligned"]["rmse"],
                    "median NEES": score.nees_summary["median"],
                }
            )
    return pd.DataFrame(rows)


if __name__ == "__main__":
    table = main()
    table[["seed", "particles"]] = table[["seed", "particles"]].astype(str)
    text = (
        "Default settings (FastSLAM 2.0), default maze runs; the map is the best-weighted particle's "
        "(`python experiments/particles/best_particle.py`).\n\n" + table.to_markdown(index=False, floatfmt=".2f") + "\n"
    )
    (HERE / "best_particle.md").write_text(text)
    print(text)
