"""The laser odometry's noise on the 8 CARMEN logs, measured against their reference poses: where
the grid filter's default motion noise (``GridSlamParams.motion_noise``) comes from.

Per log: the laser odometry with configs/carmen.toml's ``[scan_matching]``, as the grid filter moves
by it, fitted interval by interval to the motion model (``mazeslam.calibration.odometry_noise``, the
numbers ``mazeslam odometry-noise LOG --config configs/carmen.toml`` prints), and the median over
the logs. orebro has no odometry and its intervals are matched blind: its fit is the largest.
Beside it the trimmed fit (``fit_noise_trimmed``, ``--trimmed``): the same without the intervals
whose error lies beyond 3 standard deviations of the fit, at least the matcher's ``prior_floor``
(0.01 m and rad), and how many those are.

    python -m experiments.carmen_grid.motion_noise

Writes ``results/motion_noise.csv`` and ``results/motion_noise.md``.
"""

from __future__ import annotations

import pandas as pd

from experiments.carmen_grid.run import CONFIG, LOGS, RESULTS, imported_run
from mazeslam.calibration.odometry_noise import fit_noise, fit_noise_trimmed, motion_stretch_errors
from mazeslam.pipeline import load_slam_config
from mazeslam.registration.scan_matching import laser_odometry


def fit_row(name: str) -> dict:
    """The laser odometry's fitted noise on one log."""
    run = imported_run(name)
    config = load_slam_config(CONFIG)
    laser = laser_odometry(run.log, run.geometry, config.scan_matching)
    errors = motion_stretch_errors(run.log, run.truth, laser)
    measured, trimmed = fit_noise(errors), fit_noise_trimmed(errors, config.scan_matching.prior_floor)
    return {
        "log": name,
        "intervals": measured.stretches,
        "driven_m": measured.distance,
        "turned_rad": measured.turn,
        "sigmaX": measured.noise.sigmaX,
        "sigmaTH": measured.noise.sigmaTH,
        "sigmaTH_drive": measured.noise.sigmaTH_drive,
        "trimmed_sigmaX": trimmed.noise.sigmaX,
        "trimmed_sigmaTH": trimmed.noise.sigmaTH,
        "trimmed_sigmaTH_drive": trimmed.noise.sigmaTH_drive,
        "left_out": trimmed.left_out,
    }


def main() -> None:
    table = pd.DataFrame([fit_row(name) for name in LOGS]).set_index("log")
    table.loc["median"] = table.median()
    table.to_csv(RESULTS / "motion_noise.csv", float_format="%.4g")
    text = (
        "The laser odometry's noise on the CARMEN logs (configs/carmen.toml's [scan_matching]) fitted "
        "against the reference poses, interval by interval: sigmaX m/sqrt(m), sigmaTH rad/sqrt(rad), "
        "sigmaTH_drive rad/sqrt(m) (mazeslam.calibration.odometry_noise); the median row gives the grid "
        "filter's default motion noise. trimmed_*: the fit without the intervals beyond 3 standard deviations "
        "of it, at least the matcher's prior_floor (left_out of them, the failed matches; fit_noise_trimmed); "
        "their median row gives corner FastSLAM's noise in configs/carmen.toml.\n\n"
        + table.to_markdown(floatfmt=".4g")
        + "\n"
    )
    (RESULTS / "motion_noise.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
