"""Benchmark: laser odometry speed on real CARMEN logs (shared/data/carmen).

With wheel odometry (aces, ICP from the odometry prior): the log's own duration over the wall-clock
time, target 100x real time. Without (orebro, every interval seeded by the correlative search):
scans per second, target 5 (orebro's log has no usable timestamps). One core, one pass each;
skipped when the shared data is absent.
Run: ``python benchmarks/bench_scan_matching.py``.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import pandas as pd

from mazeslam.data import log
from mazeslam.data.carmen import import_carmen
from mazeslam.data.loaded_run import load_run
from mazeslam.registration.scan_matching import ScanMatchParams, laser_odometry

CARMEN = Path(__file__).resolve().parents[2] / "shared" / "data" / "carmen"
TARGET_REAL_TIME = 100.0
TARGET_BLIND_SCANS_PER_SECOND = 5.0


def timed_laser_odometry(name: str, folder: Path) -> tuple[log.CourseLog, float]:
    """Import one CARMEN log and time its laser odometry (seconds)."""
    course = folder / f"{name}.log"
    import_carmen(CARMEN / f"{name}-corrected.log.gz", course)
    run = load_run(course)
    began = time.perf_counter()
    laser_odometry(run.log, run.geometry, ScanMatchParams(enabled=True))
    return run.log, time.perf_counter() - began


def run() -> list[dict]:
    if not CARMEN.exists():
        return [{"benchmark": "laser odometry, aces and orebro", "skipped": f"no CARMEN logs at {CARMEN}"}]
    with tempfile.TemporaryDirectory() as folder:
        aces, aces_seconds = timed_laser_odometry("aces", Path(folder))
        orebro, orebro_seconds = timed_laser_odometry("orebro", Path(folder))
    factor = aces.duration / aces_seconds
    blind_rate = orebro.is_scan.sum() / orebro_seconds
    return [
        {
            "benchmark": "laser odometry, aces (wheel prior)",
            "value": factor,
            "unit": "x real time",
            "target": TARGET_REAL_TIME,
            "met": factor >= TARGET_REAL_TIME,
        },
        {
            "benchmark": "laser odometry, orebro (no odometry: correlative search)",
            "value": blind_rate,
            "unit": "scans/s",
            "target": TARGET_BLIND_SCANS_PER_SECOND,
            "met": blind_rate >= TARGET_BLIND_SCANS_PER_SECOND,
        },
    ]


if __name__ == "__main__":
    print(pd.DataFrame(run()).set_index("benchmark").to_markdown(floatfmt=".3g"))
