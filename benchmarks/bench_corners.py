"""Benchmark: corner extraction speed and quality on simulated mazes.

Speed: 180-beam scans per second on one core (target 2000), extracting from the scans of a
simulated run; reported with the ratio to the target. Quality: precision and recall of the fixed
landmarks within 2 cm of the true corners, over 3 random 6 x 6 mazes, as the laser's range noise
grows: with the default settings (tuned for 3 mm) and with the noise model and split/merge
thresholds scaled to the noise.
Run: ``python benchmarks/bench_corners.py``.
"""

from __future__ import annotations

import dataclasses
import tempfile
import time
from pathlib import Path

import pandas as pd

from mazeslam import simulate
from mazeslam.data import log, sidecars
from mazeslam.evaluation.corner_quality import evaluate_log
from mazeslam.features.corners import CornerExtractor, CornerParams
from mazeslam.sim.simulator import MazeParams, SimulationConfig

TARGET_SCANS_PER_SECOND = 2000.0
NOISE_LEVELS = (0.0, 0.003, 0.006, 0.01, 0.02)
SEEDS = (1, 2, 3)


def speed(folder: Path) -> dict:
    result = simulate(folder / "speed.log", seed=0, progress=False)
    scans = log.read(result.log_path).scans
    geometry = sidecars.beam_geometry(sidecars.read_map(result.map_path)["sensor"])
    extractor = CornerExtractor(geometry, scans.shape[1])
    best = float("inf")
    for _ in range(5):
        start = time.perf_counter()
        for ranges in scans:
            extractor.extract(ranges)
        best = min(best, (time.perf_counter() - start) / len(scans))
    return {
        "benchmark": "corner extraction, 180 beams",
        "scans_per_second": 1 / best,
        "target": TARGET_SCANS_PER_SECOND,
        "ratio_to_target": 1 / best / TARGET_SCANS_PER_SECOND,
        "met": 1 / best >= TARGET_SCANS_PER_SECOND,
    }


def settings_for_noise(noise: float) -> CornerParams:
    """The default settings with the noise model and thresholds scaled to a range noise (m)."""
    base = CornerParams()
    threshold = max(base.lines.split_threshold, 4 * noise)
    lines = dataclasses.replace(
        base.lines, range_noise_std=max(noise, 1e-4), split_threshold=threshold, merge_threshold=threshold
    )
    return dataclasses.replace(base, lines=lines)


def quality(folder: Path) -> pd.DataFrame:
    """Mean precision and recall over the seeds, per noise level, for the default settings and for
    settings scaled to the noise."""
    rows = []
    for noise in NOISE_LEVELS:
        base = SimulationConfig()
        config = dataclasses.replace(
            base, maze=MazeParams(rows=6, cols=6), laser=dataclasses.replace(base.laser, range_noise_std=noise)
        )
        for seed in SEEDS:
            result = simulate(folder / f"q{noise}-{seed}.log", config=config, seed=seed, progress=False)
            for settings, params in (("default", CornerParams()), ("scaled to noise", settings_for_noise(noise))):
                rows.append({"range_noise_m": noise, "settings": settings, **evaluate_log(result.log_path, params)})
    table = pd.DataFrame(rows)
    return table.groupby(["range_noise_m", "settings"]).agg(
        precision=("precision", "mean"),
        recall=("recall", "mean"),
        median_error_m=("median_error_m", "mean"),
        detections=("detections", "sum"),
        observable=("observable", "sum"),
    )


if __name__ == "__main__":
    with tempfile.TemporaryDirectory() as folder:
        print(pd.DataFrame([speed(Path(folder))]).set_index("benchmark").to_markdown(floatfmt=".3g"), end="\n\n")
        print(quality(Path(folder)).to_markdown(floatfmt=".4f"))
