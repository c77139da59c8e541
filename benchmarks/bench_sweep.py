"""Benchmark: the speed-up from 1 to 2 local workers on the first 27 runs of the exercise's core
grid (configs/sweeps/core_grid.toml; one seed of every cell), measured in the same run (target:
at least 1.8x; wall clock, so it needs two otherwise idle cores), and the whole grid (270 runs) on
this machine's cores (target: under 15 minutes).
Run: ``python benchmarks/bench_sweep.py``.
"""

from __future__ import annotations

import dataclasses
import os
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

from mazeslam.evaluation.sweep import load_sweep, run_sweep

GRID = Path(__file__).resolve().parents[1] / "configs" / "sweeps" / "core_grid.toml"
TARGET_SECONDS = 15 * 60
TARGET_SPEEDUP = 1.8


def _subset(sweep, count: int):
    """The same sweep restricted to its first ``count`` runs (the first seeds of the first cells)."""
    seeds = sweep.seeds[: max(1, count // max(1, len(sweep.runs()) // len(sweep.seeds)))]
    return dataclasses.replace(sweep, seeds=seeds)


def run() -> Iterator[dict]:
    """The rows, each yielded as soon as it is measured."""
    sweep = load_sweep(GRID)
    subset = _subset(sweep, 27)
    timings = {}
    with tempfile.TemporaryDirectory() as folder:
        for workers in (1, 2):
            began = time.perf_counter()
            run_sweep(subset, Path(folder) / f"subset{workers}", workers=workers, progress=False)
            timings[workers] = time.perf_counter() - began
        speedup = timings[1] / timings[2]
        yield {
            "benchmark": f"{len(subset.runs())} runs of the core grid: 2 workers over 1",
            "seconds": timings[2],
            "baseline_s": timings[1],
            "ratio": speedup,
            "target": TARGET_SPEEDUP,
            "met": speedup >= TARGET_SPEEDUP,
        }
        began = time.perf_counter()
        result = run_sweep(sweep, Path(folder) / "grid", workers=os.cpu_count(), progress=False)
        whole = time.perf_counter() - began
        yield {
            "benchmark": f"core grid, {len(result.table)} runs, {os.cpu_count()} workers",
            "seconds": whole,
            "target": TARGET_SECONDS,
            "met": whole <= TARGET_SECONDS,
        }


if __name__ == "__main__":
    import pandas as pd

    for row in run():
        print(pd.DataFrame([row]).set_index("benchmark").to_markdown(floatfmt=".3g"), end="\n\n")
