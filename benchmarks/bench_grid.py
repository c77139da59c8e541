"""Benchmark: the grid filter (mazeslam.gridslam) with 30 particles on one core, against real time.

The CARMEN log aces (shared/data/carmen) with configs/carmen.toml, through ``run_slam`` as the slam
command runs it: the log's own duration over the filter's wall-clock time (laser odometry
included), target faster than real time (ratio >= 1), and the process's peak memory (MB). Skipped
when the shared data is absent. The simulated ring building (mazeslam.sim.building) is timed
too: scans per second, as it has no real clock to compare with.
Run: ``python benchmarks/bench_grid.py``.
"""

from __future__ import annotations

import resource
import tempfile
import time
from pathlib import Path

import pandas as pd

from mazeslam.core.config import with_settings
from mazeslam.data.carmen import import_carmen
from mazeslam.data.loaded_run import load_run
from mazeslam.data.log import read
from mazeslam.gridslam import GridSlamParams, run_grid_slam
from mazeslam.pipeline import load_slam_config, run_slam
from mazeslam.sim.building import simulate_building_log

CARMEN = Path(__file__).resolve().parents[2] / "shared" / "data" / "carmen"
CONFIGS = Path(__file__).resolve().parents[1] / "configs"
PARTICLES = 30
TARGET_REAL_TIME = 1.0
TARGET_PEAK_MB = 500.0


def simulated_rate(folder: Path) -> dict:
    """Scans per second on the simulated ring building."""
    simulated = simulate_building_log(folder / "building.log")
    course_log = read(simulated.path)
    began = time.perf_counter()
    result = run_grid_slam(course_log, simulated.geometry, simulated.start_pose, GridSlamParams(particles=PARTICLES))
    rate = len(result.scan_records) / (time.perf_counter() - began)
    return {"benchmark": f"grid SLAM, simulated building, {PARTICLES} particles", "value": rate, "unit": "scans/s"}


def aces_rows(folder: Path) -> list[dict]:
    """Real-time factor and peak memory on aces."""
    if not CARMEN.exists():
        print(f"grid SLAM benchmark on aces skipped: no CARMEN logs at {CARMEN}")
        return []
    import_carmen(CARMEN / "aces-corrected.log.gz", folder / "aces.log")
    run = load_run(folder / "aces.log")
    config = with_settings(load_slam_config(CONFIGS / "carmen.toml"), {"grid.particles": PARTICLES})
    began = time.perf_counter()
    run_slam(run, config, progress=False)  # what `mazeslam slam aces.log --config configs/carmen.toml` runs
    factor = run.log.duration / (time.perf_counter() - began)
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    return [
        {
            "benchmark": f"grid SLAM, aces, {PARTICLES} particles",
            "value": factor,
            "unit": "x real time",
            "target": TARGET_REAL_TIME,
            "met": factor >= TARGET_REAL_TIME,
        },
        {
            "benchmark": "grid SLAM, peak memory of the process",
            "value": peak,
            "unit": "MB",
            "target": TARGET_PEAK_MB,
            "met": peak <= TARGET_PEAK_MB,
        },
    ]


def run() -> list[dict]:
    with tempfile.TemporaryDirectory() as folder:
        return [simulated_rate(Path(folder))] + aces_rows(Path(folder))


if __name__ == "__main__":
    print(pd.DataFrame(run()).set_index("benchmark").to_markdown(floatfmt=".3g"))
