"""Run every benchmark, printing each one's table as soon as it finishes (ratios are measured
within this run), and a last line of how many targets were met. Exits non-zero when one is missed.

``--cpu-time`` (or ``MAZESLAM_BENCH_CLOCK=cpu``): the single-process benchmarks that support it
(FastSLAM, the environment) count this process's CPU time instead of the wall clock, for a machine
shared with other work. The sweep's speed-up from one to two workers is wall-clock time: it needs
two otherwise idle cores.
"""

from __future__ import annotations

import sys
import tempfile
import time
from collections.abc import Callable, Iterable
from pathlib import Path

import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parent))

import bench_command  # noqa: E402
import bench_corners  # noqa: E402
import bench_env  # noqa: E402
import bench_fastslam  # noqa: E402
import bench_grid  # noqa: E402
import bench_laser  # noqa: E402
import bench_scan_matching  # noqa: E402
import bench_simulation  # noqa: E402
import bench_sweep  # noqa: E402
import bench_vector_env  # noqa: E402


def benchmarks(folder: Path) -> list[tuple[str, Callable[[], Iterable[dict]]]]:
    """(name, rows) of every benchmark, in the order they run; ``rows`` may yield them one by one."""
    return [
        ("laser", lambda: [bench_laser.run()]),
        ("simulation", bench_simulation.run),
        ("corner extraction", lambda: [bench_corners.speed(folder)]),
        ("FastSLAM", bench_fastslam.run),
        ("grid filter", bench_grid.run),
        ("slam command", bench_command.run),
        ("laser odometry", bench_scan_matching.run),
        ("environment", lambda: [bench_env.run()]),
        ("vector environment", bench_vector_env.run),
        ("sweeps", bench_sweep.run),
    ]


def main() -> int:
    met, missed = 0, []
    with tempfile.TemporaryDirectory() as folder:
        for name, rows in benchmarks(Path(folder)):
            began = time.perf_counter()
            for row in rows():
                print(pd.DataFrame([row]).set_index("benchmark").to_markdown(floatfmt=".3g"), end="\n\n", flush=True)
                if "met" in row:
                    met += bool(row["met"])
                    missed += [] if row["met"] else [row["benchmark"]]
            print(f"({name}: {time.perf_counter() - began:.0f} s)\n", flush=True)
        print(bench_corners.quality(Path(folder)).to_markdown(floatfmt=".4f"), end="\n\n")
    print(f"{met} targets met, {len(missed)} missed" + "".join(f"\n  missed: {name}" for name in missed))
    return 1 if missed else 0


if __name__ == "__main__":
    raise SystemExit(main())
