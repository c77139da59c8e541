"""Benchmark: sweeps on 1 and 2 local workers, and the exercise's whole core grid (issues 5 and 18).

1. The first 27 runs of the core grid (configs/sweeps/core_grid.toml; one seed of every cell) on
   1 worker and on 2, each in a fresh interpreter (so each pays its own first-use imports, as a
   user's sweep does), timed around ``run_sweep``: the wall-clock speed-up (target: at least 1.8x;
   it needs two cores free of other work) and the CPU-time efficiency, one worker's CPU time over
   the two workers' (the sweep's process and its workers: user + system time, ``getrusage``), which
   measures the parallel overhead (process start-up, pickling, imports in each worker, work done
   twice) whatever else the machine is running: 1.0 is none. ``--repeats N`` alternates the two N times;
   ``--runs N`` takes the first N runs instead, rounded to whole seeds (27 runs a seed; ``--runs 270``:
   the whole grid, the issue's own measure, about 4 and 2 minutes on two free cores).
2. The whole grid (270 runs) on this machine's cores (target: under 15 minutes; ``--subset`` skips it,
   ``--grid`` runs only it).
``--tasks`` instead times each task of the subset in this process (CPU time; the simulations, the
batch optima, the filter runs, in the sweep's order) and the makespan of two workers taking them in
that order phase by phase: the speed-up the schedule allows on two free cores, whatever the load.
Run: ``python benchmarks/bench_sweep.py [--subset | --grid | --tasks] [--repeats N] [--runs N]``.
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

from mazeslam.sweeps.runner import load_sweep, run_sweep

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


def measure(workers: int, out_dir: Path, runs: int = SUBSET_RUNS) -> dict:
    """Run the first ``runs`` runs (whole seeds, ``_subset``) on ``workers`` workers in this process:
    wall-clock and CPU seconds."""
    subset = _subset(load_sweep(GRID), runs)
    cpu, began = _cpu_seconds(), time.perf_counter()
    run_sweep(subset, out_dir, workers=workers, progress=False)
    return {"wall": time.perf_counter() - began, "cpu": _cpu_seconds() - cpu, "runs": len(subset.runs())}


def schedule_bound(workers: int = 2, count: int = SUBSET_RUNS) -> Iterator[dict]:
    """Each task of the first ``count`` runs, in ``run_sweep``'s order and phases, timed in this process (CPU
    seconds), and the makespan of ``workers`` workers each taking the next task when free (the
    pool's order): one row per phase, then the whole sweep's tasks over that makespan."""
    import scipy.optimize  # noqa: F401  (loaded before the tasks, as the sweep's process does before forking)

    from mazeslam.sweeps import runner as sweeps

    subset = _subset(load_sweep(GRID), count)
    runs = sorted(subset.runs(), key=lambda run: -sweeps.configure(subset, run["settings"])[1].fastslam.NPARTICLES)
    total = makespan = 0.0
    with tempfile.TemporaryDirectory() as logs, tempfile.TemporaryDirectory() as maps:
        phases = (
            ("simulations", sweeps.simulate_run, {sweeps.simulation_key(subset, r): r for r in runs}.values(), (logs,)),
            ("batch optima", sweeps.optimum_run, {sweeps.optimum_key(subset, r): r for r in runs}.values(), (logs,)),
            ("filter runs", sweeps.execute_run, runs, (maps, logs)),
        )
        for name, function, calls, extra in phases:
            seconds, free = [], [0.0] * workers
            for run in calls:
                began = time.process_time()
                function(subset, run, *extra)
                seconds.append(time.process_time() - began)
                free[free.index(min(free))] += seconds[-1]
            total, makespan = total + sum(seconds), makespan + max(free)
            yield {
                "benchmark": f"{name}: {len(seconds)} tasks of {min(seconds):.2f}-{max(seconds):.2f} s",
                "seconds": max(free),
                "baseline_s": sum(seconds),
                "ratio": sum(seconds) / max(free),
            }
    yield {
        "benchmark": f"{len(runs)} runs: tasks' CPU time over the {workers}-worker makespan (speed-up bound)",
        "seconds": makespan,
        "baseline_s": total,
        "ratio": total / makespan,
    }


def _measure_fresh(workers: int, out_dir: Path, runs: int) -> dict:
    """``measure`` in a fresh interpreter."""
    command = [sys.executable, __file__, "--measure", str(workers), str(out_dir), str(runs)]
    printed = subprocess.run(command, check=True, capture_output=True, text=True).stdout
    return json.loads(printed.splitlines()[-1])


def run(
    subset_only: bool = False, repeats: int = 1, grid_only: bool = False, runs: int = SUBSET_RUNS
) -> Iterator[dict]:
    """The rows, each yielded as soon as it is measured."""
    timings: dict[int, list[dict]] = {1: [], 2: []}
    loads = []
    with tempfile.TemporaryDirectory() as folder:
        for repeat in range(0 if grid_only else repeats):
            for workers in (1, 2):
                loads.append(os.getloadavg()[0])
                timings[workers].append(_measure_fresh(workers, Path(folder) / f"subset{workers}-{repeat}", runs))
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
        print(json.dumps(measure(int(sys.argv[2]), Path(sys.argv[3]), int(sys.argv[4]))))
        raise SystemExit(0)
    import pandas as pd

    repeats = int(sys.argv[sys.argv.index("--repeats") + 1]) if "--repeats" in sys.argv else 1
    runs = int(sys.argv[sys.argv.index("--runs") + 1]) if "--runs" in sys.argv else SUBSET_RUNS
    rows = (
        schedule_bound(count=runs)
        if "--tasks" in sys.argv
        else run(subset_only="--subset" in sys.argv, repeats=repeats, grid_only="--grid" in sys.argv, runs=runs)
    )
    for row in rows:
        print(pd.DataFrame([row]).set_index("benchmark").to_markdown(floatfmt=".3g"), end="\n\n", flush=True)
