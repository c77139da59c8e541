"""Benchmark: how much faster than real time a whole simulated run goes, on default rates.

Baseline: the run's own simulated duration (real time). Measures the default run (random 4 x 4
maze, full exploration tour) and a 16 x 16 maze for 600 simulated seconds, writing the logs to a
temporary folder. Target: at least 200x faster than real time. Run:
``python benchmarks/bench_simulation.py``.
"""

from __future__ import annotations

import dataclasses
import tempfile
import time
from pathlib import Path

from mazeslam import simulate
from mazeslam.sim.simulator import MazeParams, SimulationConfig

TARGET_REAL_TIME_FACTOR = 200.0


def measure(name: str, config: SimulationConfig, duration: float | None, folder: Path) -> dict:
    start = time.perf_counter()
    result = simulate(folder / f"{name}.log", config=config, seed=0, duration=duration, progress=False)
    elapsed = time.perf_counter() - start
    simulated = float(result.times[-1])
    return {
        "benchmark": f"simulate {name}",
        "simulated_s": simulated,
        "wall_clock_s": elapsed,
        "real_time_factor": simulated / elapsed,
        "target": TARGET_REAL_TIME_FACTOR,
        "met": simulated / elapsed >= TARGET_REAL_TIME_FACTOR,
    }


def run() -> list[dict]:
    big = dataclasses.replace(SimulationConfig(), maze=MazeParams(rows=16, cols=16))
    with tempfile.TemporaryDirectory() as folder:
        return [
            measure("default 4x4 tour", SimulationConfig(), None, Path(folder)),
            measure("16x16, 600 s", big, 600.0, Path(folder)),
        ]


if __name__ == "__main__":
    for row in run():
        print(row)
