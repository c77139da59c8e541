"""The laser odometry's noise on the 8 CARMEN logs, measured against their reference poses: where
the grid filter's default motion noise (``GridSlamParams.motion_noise``) comes from.

Per log: the laser odometry with configs/carmen.toml's ``[scan_matching]``, as the grid filter moves
by it, fitted interval by interval to the motion model (``mazeslam.evaluation.odometry_noise``, the
numbers ``mazeslam odometry-noise LOG --config configs/carmen.toml`` prints), and the median over
the logs. orebro has no odometry and its intervals are matched blind: its fit is the largest.

    python experiments/carmen_grid/motion_noise.py

Writes ``results/motion_noise.csv`` and ``results/motion_noise.md``.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import pandas as pd
from run import CARMEN, CONFIG, LOGS, RESULTS  # this folder's run.py

from mazeslam.evaluation.odometry_noise import measure_motion_noise
from mazeslam.filters.scan_matching import laser_odometry
from mazeslam.imports.carmen import import_carmen
from mazeslam.loaded_run import load_run
from mazeslam.slam import load_slam_config


def fit_row(name: str) -> dict:
    """The laser odometry's fitted noise on one log."""
    with tempfile.TemporaryDirectory() as folder:
        course = Path(folder) / f"{name}.log"
        import_carmen(CARMEN / f"{name}-corrected.log.gz", course)
        run = load_run(course)
    config = load_slam_config(CONFIG)
    laser = laser_odometry(run.log, run.geometry, config.scan_matching)
    measured = measure_motion_noise(run.log, run.truth, laser)
    return {
        "log": name,
        "intervals": measured.stretches,
        "driven_m": measured.distance,
        "turned_rad": measured.turn,
        "sigmaX": measured.noise.sigmaX,
        "sigmaTH": measured.noise.sigmaTH,
        "sigmaTH_drive": measured.noise.sigmaTH_drive,
    }


def main() -> None:
    table = pd.DataFrame([fit_row(name) for name in LOGS]).set_index("log")
    table.loc["median"] = table.median()
    table.to_csv(RESULTS / "motion_noise.csv", float_format="%.4g")
    text = (
        "The laser odometry's noise on the CARMEN logs (configs/carmen.toml's [scan_matching]) fitted "
        "against the reference poses, interval by interval: sigmaX m/sqrt(m), sigmaTH rad/sqrt(rad), "
        "sigmaTH_drive rad/sqrt(m) (mazeslam.evaluation.odometry_noise); the median row gives the grid "
        "filter's default motion noise.\n\n" + table.to_markdown(floatfmt=".4g") + "\n"
    )
    (RESULTS / "motion_noise.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
