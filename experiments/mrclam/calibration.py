"""Where configs/mrclam.toml's noise terms come from: ``mazeslam calibrate`` on each robot of MRCLAM
Dataset 6 alone and on all five together (the pooled fit the config uses).

    python -m experiments.mrclam.calibration [--data ../shared/data/mrclam/MRCLAM_Dataset6]   (about a minute)

Writes ``calibration.md`` beside this script.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import pandas as pd

from mazeslam.calibration.noise import Calibration, calibrate_logs
from mazeslam.data.loaded_run import load_run
from mazeslam.data.mrclam import import_mrclam
from mazeslam.pipeline import load_slam_config

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
ROBOTS = [1, 2, 3, 4, 5]


def row(name: str, measured: Calibration) -> dict:
    noise, seen = measured.motion.noise, measured.observations
    assert seen is not None  # every robot sees hundreds of landmarks
    return {
        "logs": name,
        "sigmaX [m/sqrt(m)]": noise.sigmaX,
        "sigmaTH [rad/sqrt(rad)]": noise.sigmaTH,
        "sigmaTH_drive [rad/sqrt(m)]": noise.sigmaTH_drive,
        "sigmaR [m]": seen.sigmaR,
        "sigmaB [rad]": seen.sigmaB,
        "odometry stretches": measured.motion.stretches,
        "driven [m]": measured.motion.distance,
        "observations": seen.observations,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=ROOT.parent / "shared" / "data" / "mrclam" / "MRCLAM_Dataset6")
    data = parser.parse_args().data.resolve()
    config = load_slam_config(ROOT / "configs" / "mrclam.toml")
    with tempfile.TemporaryDirectory() as folder:
        runs = []
        for robot in ROBOTS:
            import_mrclam(data, robot, Path(folder) / f"robot{robot}.log")
            runs.append(load_run(Path(folder) / f"robot{robot}.log"))
        rows = [row(f"robot {robot}", calibrate_logs([run], config)) for robot, run in zip(ROBOTS, runs)]
        rows.append(row("robots 1-5 together (configs/mrclam.toml)", calibrate_logs(runs, config)))
    text = (
        "`mazeslam calibrate` on MRCLAM Dataset 6 against the motion-capture truth, each robot alone and the five "
        "together (every fit made once over all their odometry stretches and landmark observations). A single "
        "robot's non-negative fit can trade one odometry term for another (a 0 below); the pooled fit is the "
        "config's. `python -m experiments.mrclam.calibration`.\n\n"
        + pd.DataFrame(rows).set_index("logs").to_markdown(floatfmt=["", *[".3g"] * 5, ".0f", ".0f", ".0f"])
        + "\n"
    )
    (HERE / "calibration.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
