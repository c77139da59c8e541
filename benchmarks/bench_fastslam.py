"""Benchmark: the vectorised FastSLAM against a plain per-particle Python loop, and against real time.

1. Speed-up: the same records (the first 40 scans of the default simulated run, with their
   odometry) through ``FastSLAM`` and through the loop oracle ``tests/reference_fastslam.py``, at
   1000 particles, in the same run. Target: at least 30x.
2. Real-time factor: the whole default run at 1000 particles; the log's duration over the
   wall-clock time. Target: at least 10x. Peak memory of the run (tracemalloc) is reported too.
Run: ``python benchmarks/bench_fastslam.py``.
"""

from __future__ import annotations

import sys
import tempfile
import time
import tracemalloc
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from reference_fastslam import LoopFastSLAM  # noqa: E402

from mazeslam import log, simulate  # noqa: E402
from mazeslam.filters.corners import CornerExtractor  # noqa: E402
from mazeslam.filters.fastslam import FastSLAM, FastSLAMParams  # noqa: E402
from mazeslam.loaded_run import load_run  # noqa: E402
from mazeslam.slam import run_fastslam  # noqa: E402

PARTICLES = 1000
TARGET_SPEEDUP = 30.0
TARGET_REAL_TIME = 10.0


def _inputs(path, scans: int):
    run = load_run(path)
    course_log = run.log
    extractor = CornerExtractor(run.geometry, course_log.width)
    steps = []
    for record in course_log.records():
        if isinstance(record, log.OdometryRecord):
            steps.append(("predict", (record.distance, record.turn)))
        else:
            features = extractor.extract(record.ranges)
            z, covariances = features.observation_array(), features.observation_covariances()
            steps.append(("update", (z, covariances)))
            if sum(kind == "update" for kind, _ in steps) == scans:
                break
    return steps


def _time(filter_class, steps, start) -> float:
    slam = filter_class(FastSLAMParams(NPARTICLES=PARTICLES), start)
    began = time.perf_counter()
    for kind, arguments in steps:
        getattr(slam, kind)(*arguments)
    return time.perf_counter() - began


def run() -> list[dict]:
    with tempfile.TemporaryDirectory() as folder:
        path = simulate(Path(folder) / "run.log", seed=0, progress=False).log_path
        loaded = load_run(path)
        start = loaded.start_pose
        steps = _inputs(path, scans=40)
        vectorised = min(_time(FastSLAM, steps, start) for _ in range(3))
        loop = _time(LoopFastSLAM, steps, start)
        tracemalloc.start()
        began = time.perf_counter()
        run_fastslam(loaded.log, FastSLAMParams(NPARTICLES=PARTICLES), None, loaded.geometry, start, progress=False)
        elapsed = time.perf_counter() - began
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
    return [
        {
            "benchmark": f"update+predict, {PARTICLES} particles, 40 scans",
            "vectorised_s": vectorised,
            "python_loop_s": loop,
            "speedup": loop / vectorised,
            "target": TARGET_SPEEDUP,
            "met": loop / vectorised >= TARGET_SPEEDUP,
        },
        {
            "benchmark": f"default run, {PARTICLES} particles",
            "log_s": loaded.log.duration,
            "wall_clock_s": elapsed,
            "real_time_factor": loaded.log.duration / elapsed,
            "peak_memory_mb": peak / 2**20,
            "target": TARGET_REAL_TIME,
            "met": loaded.log.duration / elapsed >= TARGET_REAL_TIME,
        },
    ]


if __name__ == "__main__":
    import pandas as pd

    for row in run():
        print(pd.DataFrame([row]).set_index("benchmark").to_markdown(floatfmt=".3g"), end="\n\n")
