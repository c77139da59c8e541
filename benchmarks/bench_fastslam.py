"""Benchmark: FastSLAM against its baselines, each timed in the same run (issues 4 and 18).

1. Loop oracle: predict + update at 1000 particles over the first 40 scans of the default run,
   the vectorised filter against the per-particle loop ``tests/fastslam/reference_fastslam.py`` (FastSLAM
   1.0, the oracle's algorithm). Target: at least 100x.
2. Map size: the filter's time per particle and observation at 1000 particles on the full 16x16
   tour (``mazeslam simulate --rows 16 --cols 16 --seed 3``: about 300 corners) over that on the
   default 4x4 run (15 corners). Target: at most 1.5. With it, how much of the measurement model
   each run's scans computed (``UpdateReport.pairs``, ``within_reach``, ``modelled``).
3. Real time: that 16x16 tour's robot time over the filter's time at 1000 particles (target: at
   least 20x), and at 10 000 particles over the first quarter of its records (target: at least
   1x; ``--full`` runs the whole tour, about ten times longer).
The filter's time is ``run_fastslam`` over the log (corner extraction included), per wall-clock
second, or per second of this process's CPU time with ``--cpu-time`` (or
``MAZESLAM_BENCH_CLOCK=cpu``): on a machine shared with other work the wall clock also counts the
time others hold the cores.
Run: ``python benchmarks/bench_fastslam.py``.

``--against COMMIT [--turns N]`` instead compares this tree's filter with the code at ``COMMIT``
(its package from ``git archive``), in turns, each in a fresh interpreter: the loop-oracle row's
vectorised seconds and the map-size row's two runs, on logs simulated once.
"""

from __future__ import annotations

import dataclasses
import io
import json
import os
import subprocess
import sys
import tarfile
import tempfile
from collections.abc import Iterator
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "fastslam"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_env import clock, clock_name, uses_cpu_time  # noqa: E402  (one clock for the benchmarks that offer CPU time)
from reference_fastslam import LoopFastSLAM  # noqa: E402

from mazeslam import simulate  # noqa: E402
from mazeslam.data import log
from mazeslam.data.loaded_run import LoadedRun, load_run  # noqa: E402
from mazeslam.fastslam.filter import FastSLAM, FastSLAMParams  # noqa: E402
from mazeslam.features.corners import CornerExtractor  # noqa: E402
from mazeslam.pipeline.fastslam_run import run_fastslam  # noqa: E402
from mazeslam.sim.simulator import SimulationConfig  # noqa: E402

PARTICLES = 1000
MANY_PARTICLES = 10_000
TARGET_SPEEDUP = 100.0
TARGET_MAP_RATIO = 1.5
TARGET_REAL_TIME = 20.0
TARGET_REAL_TIME_MANY = 1.0
REPO = Path(__file__).resolve().parents[1]


def _steps(run: LoadedRun, scans: int) -> list[tuple[str, tuple]]:
    """The first ``scans`` scans of ``run`` with the odometry before them, as filter calls."""
    extractor = CornerExtractor(run.geometry, run.log.width)
    steps: list[tuple[str, tuple]] = []
    for record in run.log.records():
        if isinstance(record, log.OdometryRecord):
            steps.append(("predict", (record.distance, record.turn)))
        elif isinstance(record, log.ScanRecord):
            features = extractor.extract(record.ranges)
            steps.append(("update", (features.observation_array(), features.observation_covariances())))
            if sum(kind == "update" for kind, _ in steps) == scans:
                break
    return steps


def _time_steps(filter_class, steps, start) -> float:
    """Seconds ``filter_class`` (FastSLAM 1.0, 1000 particles) takes over ``steps``."""
    slam = filter_class(FastSLAMParams(NPARTICLES=PARTICLES, version=1), start)
    began = clock()
    for kind, arguments in steps:
        getattr(slam, kind)(*arguments)
    return clock() - began


def _time_filter(run: LoadedRun, particles: int, records: int | None = None, counts: bool = True) -> dict:
    """The filter over the first ``records`` records of ``run`` (all by default): seconds, robot
    seconds, observations and the time per particle and observation (microseconds); with
    ``counts``, the measurement model's size per scan (``UpdateReport.pairs`` ...)."""
    course_log = run.log
    if records is not None:
        course_log = log.CourseLog(course_log.times[:records], course_log.flags[:records], course_log.values[:records])
    began = clock()
    result = run_fastslam(course_log, FastSLAMParams(NPARTICLES=particles), None, run.geometry, run.start_pose, False)
    seconds = clock() - began
    reports = result.reports
    observations = sum(report.observations for report in reports)
    return {
        "seconds": seconds,
        "robot_seconds": course_log.duration,
        "observations": observations,
        "per_particle_observation_us": 1e6 * seconds / (particles * observations),
        "model_per_scan": [
            sum(getattr(report, name) for report in reports) / len(reports)
            for name in ("observations", "pairs", "within_reach", "modelled")
        ]
        if counts
        else [],
    }


def _model_size(cost: dict) -> str:
    """A run's measurement model per scan: observations, near observation-slot pairs, their
    particle triples within reach, and those left by the facing gate (means over the scans)."""
    return " / ".join(f"{value:,.0f}" if value >= 10 else f"{value:.1f}" for value in cost["model_per_scan"])


def oracle_speedup(run: LoadedRun) -> dict:
    steps = _steps(run, scans=40)
    vectorised = min(_time_steps(FastSLAM, steps, run.start_pose) for _ in range(3))
    loop = _time_steps(LoopFastSLAM, steps, run.start_pose)
    return {
        "benchmark": f"FastSLAM 1.0 predict+update, {PARTICLES} particles, 40 scans: vectorised vs loop oracle",
        "seconds": vectorised,
        "baseline_s": loop,
        "ratio": loop / vectorised,
        "target": TARGET_SPEEDUP,
        "met": loop / vectorised >= TARGET_SPEEDUP,
    }


def _simulate_small(folder: Path) -> LoadedRun:
    """The default 4x4 run (seed 0), simulated into ``folder``/small."""
    return load_run(simulate(folder / "small" / "run.log", seed=0, progress=False).log_path)


def _simulate_big(folder: Path) -> LoadedRun:
    """The 16x16 tour (seed 3), simulated into ``folder``/big."""
    default = SimulationConfig()
    config = dataclasses.replace(default, maze=dataclasses.replace(default.maze, rows=16, cols=16))
    return load_run(simulate(folder / "big" / "run.log", config, seed=3, progress=False).log_path)


def run(full: bool = False) -> Iterator[dict]:
    """The rows, each yielded as soon as it is measured (the slow ones last)."""
    with tempfile.TemporaryDirectory() as folder:
        small = _simulate_small(Path(folder))
        yield oracle_speedup(small)
        big = _simulate_big(Path(folder))
        small_cost = _time_filter(small, PARTICLES)
        big_cost = _time_filter(big, PARTICLES)
        ratio = big_cost["per_particle_observation_us"] / small_cost["per_particle_observation_us"]
        yield {
            "benchmark": f"time per particle-observation, {PARTICLES} particles: 16x16 tour over default 4x4 run",
            "seconds": big_cost["per_particle_observation_us"] * 1e-6,
            "baseline_s": small_cost["per_particle_observation_us"] * 1e-6,
            "ratio": ratio,
            "target": f"<= {TARGET_MAP_RATIO}",
            "met": ratio <= TARGET_MAP_RATIO,
        }
        yield {
            "benchmark": f"per scan, {PARTICLES} particles: observations / near pairs / triples in reach / modelled",
            "16x16 tour": _model_size(big_cost),
            "default run": _model_size(small_cost),
        }
        yield _real_time_row(f"16x16 tour, {PARTICLES} particles", big_cost, TARGET_REAL_TIME)
        records = None if full else len(big.log) // 4
        many = _time_filter(big, MANY_PARTICLES, records)
        share = "whole" if full else "first quarter of the"
        yield _real_time_row(f"{share} 16x16 tour, {MANY_PARTICLES} particles", many, TARGET_REAL_TIME_MANY)


def _real_time_row(name: str, cost: dict, target: float) -> dict:
    factor = cost["robot_seconds"] / cost["seconds"]
    return {
        "benchmark": f"real-time factor, {name}",
        "seconds": cost["seconds"],
        "baseline_s": cost["robot_seconds"],
        "ratio": factor,
        "target": target,
        "met": factor >= target,
    }


def measure(folder: Path) -> dict:
    """In this interpreter, whichever ``mazeslam`` it imports: the loop-oracle row's vectorised
    seconds (best of 3) and both runs' filter seconds, on the logs in ``folder``."""
    import mazeslam

    small, big = (load_run(folder / name / "run.log") for name in ("small", "big"))
    steps = _steps(small, scans=40)
    oracle_rows = min(_time_steps(FastSLAM, steps, small.start_pose) for _ in range(3))
    small_cost, big_cost = (_time_filter(run, PARTICLES, counts=False) for run in (small, big))
    return {
        "package": str(Path(mazeslam.__file__).parent),
        "oracle_rows_s": oracle_rows,
        "default_run_s": small_cost["seconds"],
        "tour_s": big_cost["seconds"],
        "ratio": big_cost["per_particle_observation_us"] / small_cost["per_particle_observation_us"],
    }


def against(commit: str, turns: int) -> Iterator[dict]:
    """``measure`` for the code at ``commit`` and for this tree, in turns, each in a fresh
    interpreter that imports its own package (the commit's put first on the path), on logs this
    tree simulates once."""
    with tempfile.TemporaryDirectory() as folder:
        root = Path(folder)
        _simulate_small(root)
        _simulate_big(root)
        archive = subprocess.run(
            ["git", "-C", str(REPO), "archive", commit, "mazeslam"], check=True, capture_output=True
        )
        tarfile.open(fileobj=io.BytesIO(archive.stdout)).extractall(root / "package", filter="data")
        for turn in range(turns):
            for name, path in ((commit, str(root / "package")), ("this tree", None)):
                environment = {key: value for key, value in os.environ.items() if key != "PYTHONPATH"}
                environment.update({"PYTHONPATH": path} if path else {})
                environment.update({"MAZESLAM_BENCH_CLOCK": "cpu"} if uses_cpu_time() else {})
                load = os.getloadavg()[0]
                command = [sys.executable, __file__, "--measure", str(root)]
                printed = subprocess.run(command, check=True, capture_output=True, text=True, env=environment, cwd=root)
                row = json.loads(printed.stdout.splitlines()[-1])
                assert row.pop("package").startswith(path or str(REPO)), "the interpreter imported the wrong package"
                yield {"benchmark": f"{name}, turn {turn + 1}", **row, "load_average": f"{load:.1f}"}


if __name__ == "__main__":
    if sys.argv[1:2] == ["--measure"]:
        print(json.dumps(measure(Path(sys.argv[2]))))
        raise SystemExit(0)
    import pandas as pd

    if "--against" in sys.argv:
        turns = int(sys.argv[sys.argv.index("--turns") + 1]) if "--turns" in sys.argv else 2
        rows = against(sys.argv[sys.argv.index("--against") + 1], turns)
        for row in rows:
            print(pd.DataFrame([row]).set_index("benchmark").to_markdown(floatfmt=".3g"), end="\n\n", flush=True)
        print("seconds of the", clock_name())
        raise SystemExit(0)
    for row in run(full="--full" in sys.argv):
        print(pd.DataFrame([row]).set_index("benchmark").to_markdown(floatfmt=".3g"), end="\n\n", flush=True)
    print("seconds of the", clock_name())
