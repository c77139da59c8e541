"""Benchmark: sweeps on 1 and 2 local workers, and the exercise's whole core grid (issues 5 and 18).

1. The first 27 runs of the core grid (configs/sweeps/core_grid.toml; one seed of every cell) on
   1 worker and on 2, each in a fresh interpreter (so each pays its own first-use imports, as a
   user's sweep does), timed around ``run_sweep``: the wall-clock speed-up (target: at least 1.8x;
   it needs two cores free of other work) and the CPU-time efficiency, one worker's CPU time over
   the two workers' (the sweep's process and its workers: user + system time, ``getrusage``), which
   measures the parallel overhead (process start-up, pickling, imports in each worker, work done
   twice) whatever else the machine is running: 1.0 is none. ``--repeats N`` alternates the two N times.
2. The whole grid (270 runs) on this machine's cores (target: under 15 minutes; ``--subset`` skips it,
   ``--grid`` runs only it).
Run: ``python benchmarks/bench_sweep.py [--subset | --grid] [--repeats N]``.
"""

from __future__ import annotations

import dataclasses
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

from mazeslam.evaluation.sweep import load_sweep, run_sweep

GRID = Path(__file__).resolve().parents[1] / "configs" / "sweeps" / "core_grid.toml"
TARGET_SECONDS = 15 * 60
TARGET_SPEEDUP = 1.8
SUBSET_RUNS = 27


def _subset(sweep, count: int):
    """The same sweep restricted to its first ``count`` runs (the first seeds of the first cells)."""
    seeds = sweep.seeds[: max(1, count // max(1, len(sweep.runs()) // len(sweep.seeds)))]
    return dataclasses.replace(sweep, seeds=seeds)


def _cpu_seconds() -> float:
    """User + system seconds of this process and of its finished (waited-for) children."""
    own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def measure(workers: int, out_dir: Path) -> dict:
    """Run the subset on ``workers`` workers in this process: its wall-clock and CPU seconds."""
    subset = _subset(load_sweep(GRID), SUBSET_RUNS)
    cpu, began = _cpu_seconds(), time.perf_counter()
    run_sweep(subset, out_dir, workers=workers, progress=False)
    return {"wall": time.perf_counter() - began, "cpu": _cpu_seconds() - cpu, "runs": len(subset.runs())}


def _measure_fresh(workers: int, out_dir: Path) -> dict:
    """``measure`` in a fresh interpreter."""
    command = [sys.executable, __file__, "--measure", str(workers), str(out_dir)]
    printed = subprocess.run(command, check=True, capture_output=True, text=True).stdout
    return json.loads(printed.splitlines()[-1])


def run(subset_only: bool = False, repeats: int = 1, grid_only: bool = False) -> Iterator[dict]:
    """The rows, each yielded as soon as it is measured."""
    timings: dict[int, list[dict]] = {1: [], 2: []}
    loads = []
    with tempfile.TemporaryDirectory() as folder:
        for repeat in range(0 if grid_only else repeats):
            for workers in (1, 2):
                loads.append(os.getloadavg()[0])
                timings[workers].append(_measure_fresh(workers, Path(folder) / f"subset{workers}-{repeat}"))
        if not grid_only:
            yield from _subset_rows(timings, loads, repeats)
        if subset_only:
            return
        sweep = load_sweep(GRID)
        load = os.getloadavg()[0]
        began = time.perf_counter()
        result = run_sweep(sweep, Path(folder) / "grid", workers=os.cpu_count(), progress=False)
        whole = time.perf_counter() - began
        yield {
            "benchmark": f"core grid, {len(result.table)} runs, {os.cpu_count()} workers",
            "seconds": whole,
            "target": TARGET_SECONDS,
            "met": whole <= TARGET_SECONDS,
            "load_average": f"{load:.1f}-{os.getloadavg()[0]:.1f}",
        }


def _subset_rows(timings: dict[int, list[dict]], loads: list[float], repeats: int) -> Iterator[dict]:
    """The speed-up row (wall clock, the best of each) and the CPU-time efficiency row."""
    one, two = (min(timings[w], key=lambda t: t["wall"]) for w in (1, 2))
    speedup = one["wall"] / two["wall"]
    yield {
        "benchmark": f"{one['runs']} runs of the core grid: 2 workers over 1 (wall clock, best of {repeats})",
        "seconds": two["wall"],
        "baseline_s": one["wall"],
        "ratio": speedup,
        "target": TARGET_SPEEDUP,
        "met": speedup >= TARGET_SPEEDUP,
        "load_average": f"{min(loads):.1f}-{max(loads):.1f}",
    }
    cpu_one = min(t["cpu"] for t in timings[1])
    cpu_two = min(t["cpu"] for t in timings[2])
    yield {
        "benchmark": f"{one['runs']} runs of the core grid: CPU time of 1 worker over 2 workers' (1 = no overhead)",
        "seconds": cpu_two,
        "baseline_s": cpu_one,
        "ratio": cpu_one / cpu_two,
    }


if __name__ == "__main__":
    if sys.argv[1:2] == ["--measure"]:
        print(json.dumps(measure(int(sys.argv[2]), Path(sys.argv[3]))))
        raise SystemExit(0)
    import pandas as pd

    repeats = int(sys.argv[sys.argv.index("--repeats") + 1]) if "--repeats" in sys.argv else 1
    for row in run(subset_only="--subset" in sys.argv, repeats=repeats, grid_only="--grid" in sys.argv):
        print(pd.DataFrame([row]).set_index("benchmark").to_markdown(floatfmt=".3g"), end="\n\n", flush=True)
