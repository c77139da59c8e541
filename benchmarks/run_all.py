"""Run every benchmark and print one Markdown table (ratios are measured within this run)."""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parent))

import bench_corners  # noqa: E402
import bench_env  # noqa: E402
import bench_fastslam  # noqa: E402
import bench_laser  # noqa: E402
import bench_scan_matching  # noqa: E402
import bench_simulation  # noqa: E402
import bench_sweep  # noqa: E402
import bench_vector_env  # noqa: E402


def main() -> int:
    with tempfile.TemporaryDirectory() as folder:
        tables = [
            pd.DataFrame([bench_laser.run()]),
            pd.DataFrame(bench_simulation.run()),
            pd.DataFrame([bench_corners.speed(Path(folder))]),
        ]
        tables += [pd.DataFrame([row]) for row in bench_fastslam.run()]
        tables += [pd.DataFrame([row]) for row in bench_sweep.run()]
        tables += [pd.DataFrame([row]) for row in bench_scan_matching.run()]
        tables.append(pd.DataFrame([bench_env.run()]))
        tables.append(pd.DataFrame(bench_vector_env.run()))
        for table in tables:
            print(table.set_index("benchmark").to_markdown(floatfmt=".3g"), end="\n\n")
        print(bench_corners.quality(Path(folder)).to_markdown(floatfmt=".4f"))
    return 0 if all(table["met"].all() for table in tables if "met" in table) else 1


if __name__ == "__main__":
    raise SystemExit(main())
