"""Corner FastSLAM on the 8 CARMEN building logs: import, map, score against the reference poses.

    python experiments/carmen/run.py        (a few minutes; writes results/ beside this file)

For each log: ``mazeslam import carmen`` then FastSLAM with configs/carmen.toml (one setting for
the family); the ATE of dead reckoning and of FastSLAM against the reference poses (gmapping's
corrected poses: a reference, not ground truth), with and without SE(2) alignment; landmarks,
run time, particles; the final map drawn over the scans.
"""

from __future__ import annotations

import time
from pathlib import Path

import pandas as pd

from mazeslam import log, sidecars
from mazeslam.evaluation import slam_report
from mazeslam.evaluation.metrics import absolute_trajectory_error
from mazeslam.filters.motion import dead_reckoning
from mazeslam.imports.carmen import import_carmen
from mazeslam.scans import resolve_geometry
from mazeslam.slam import load_slam_config, slam_on_file

HERE = Path(__file__).resolve().parent
PROJECT = HERE.parents[1]
DATA = PROJECT.parent / "shared" / "data" / "carmen"
LOGS = ["aces", "csail", "edmonton", "fhw", "freiburg-079", "freiburg-101", "orebro", "seattle"]


def main():
    out = HERE / "results"
    out.mkdir(exist_ok=True)
    config = load_slam_config(PROJECT / "configs" / "carmen.toml")
    rows = []
    for name in LOGS:
        course = out / f"{name}.log"
        import_carmen(DATA / f"{name}-corrected.log.gz", course)
        course_log = log.read(course)
        _, reference = sidecars.read_truth(sidecars.truth_path(course))
        start = sidecars.read_map(sidecars.map_path(course))["start_pose"]
        reckoned = dead_reckoning(course_log, start)
        began = time.perf_counter()
        result = slam_on_file(course, config, progress=False)
        seconds = time.perf_counter() - began
        row = {"log": name, "scans": int(course_log.is_scan.sum()), "particles": config.fastslam.NPARTICLES}
        for label, poses in (("odometry", reckoned), ("FastSLAM", result.mean_poses)):
            row[f"{label} ATE [m]"] = absolute_trajectory_error(poses, reference)["rmse"]
            row[f"{label} ATE aligned [m]"] = absolute_trajectory_error(poses, reference, align=True)["rmse"]
        row.update({"landmarks": len(result.landmarks), "FastSLAM s": seconds})
        rows.append(row)
        geometry, _ = resolve_geometry(course)
        points = slam_report.scan_points_world(course_log, result.mean_poses, geometry, 0.1, config.corners.max_range)
        slam_report.plot_slam(out / f"{name}.png", result, points[::5], reference, None, title=f"{name}: FastSLAM")
        for suffix in (".log", ".truth.csv", ".map.json"):
            course.with_name(course.stem + suffix).unlink()
        print(row, flush=True)
    table = pd.DataFrame(rows)
    (out / "table.md").write_text(table.to_markdown(index=False, floatfmt=".2f") + "\n")
    print(table.to_markdown(index=False, floatfmt=".2f"))


if __name__ == "__main__":
    main()
