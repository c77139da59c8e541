"""The course robot's filters compared - dead reckoning, corner FastSLAM and the grid filter.

On log1 (no truth): map sharpness (occupied 1 cm cells of the 0.05-0.4 m returns placed along the
path, over dead reckoning's) and path extent (bounding-box diagonal, over dead reckoning's) for
filter seeds 0-4. On simulated course-robot logs (configs/simulation_course_robot.toml, seeds
201-205, not used for choosing any setting): ATE, pose NEES and the same sharpness, with the true
path's extent beside the estimates' (dead reckoning's path grows as it drifts, so an extent under
1 is not by itself a shrunken estimate). Both filters with configs/course.toml, its ``[map] kind``
set to each: the grid filter with its ``[grid]``, corner FastSLAM with its ``[fastslam]`` and ``[corners]``.

    python -m experiments.course_robot.filters    # about 25 min on one core

Writes experiments/course_robot/filters.csv (a row per log, filter, seed and path) and filters.md
(the per-log medians and worst values), adding rows to the CSV as they come.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from mazeslam.core.config import with_settings
from mazeslam.data.beam_detection import loaded_with_convention
from mazeslam.data.loaded_run import LoadedRun, load_run
from mazeslam.evaluation.consistency import nees_summary
from mazeslam.evaluation.metrics import absolute_trajectory_error, normalized_estimation_error
from mazeslam.evaluation.sharpness import dead_reckoning_without_glitches, path_extent, paths_sharpness
from mazeslam.gridslam.filter import odometry_at_record_times
from mazeslam.pipeline import MapKind, SlamConfig, load_slam_config, run_slam
from mazeslam.sim.simulator import load_config, simulate

HERE = Path(__file__).resolve().parent
PROJECT = HERE.parents[1]
LOG1 = PROJECT.parent / "shared" / "data" / "course" / "log1.txt"
SIMULATION = PROJECT / "configs" / "simulation_course_robot.toml"
COURSE = PROJECT / "configs" / "course.toml"
FILTER_SEEDS = range(5)
SIMULATION_SEEDS = range(201, 206)
TABLE = HERE / "filters.csv"
#: Where the rows go while the script runs; it replaces ``TABLE`` once every row is in.
PARTIAL = HERE / "filters.csv.partial"
FILTER_NAMES = {MapKind.GRID: "grid filter", MapKind.LANDMARKS: "corner FastSLAM"}
COLUMNS = ["log", "filter", "seed", "path", "sharpness_ratio", "extent_ratio", "final_cloud_max_m", "ate_rmse_m"]
COLUMNS += ["dead_reckoning_ate_rmse_m", "odometry_ate_rmse_m", "true_extent_ratio", "nees_median", "motion_nis_mean"]


def estimate(run: LoadedRun, config: SlamConfig, kind: MapKind, seed: int) -> tuple[dict[str, tuple], dict]:
    """The mean path (R, 3) with its covariances (R, 3, 3) and the best particle's path (R, 3, no
    covariance) of one filter run over every record of ``run``; and its run-wide columns: how far
    the farthest particle of the final cloud is from its weighted mean, m (a split cloud: far), and
    the grid filter's mean motion NIS (``mazeslam.gridslam.filter.motion_nis``; corner FastSLAM's NIS
    is per observation, in the slam command's output)."""
    result = run_slam(run, with_settings(config, {"map.kind": kind}).with_seed(seed), progress=False)
    paths = {"mean": (result.mean_poses, result.pose_covariances), "best": (result.best_poses, None)}
    if kind == MapKind.GRID:
        particles = result.grid_run.particles
        farthest = _farthest(particles.poses, particles.weights)
        return paths, {"final_cloud_max_m": farthest, "motion_nis_mean": float(np.mean(result.nis))}
    return paths, {"final_cloud_max_m": _farthest(result.filter.poses, result.filter.weights())}


def _farthest(poses: np.ndarray, weights: np.ndarray) -> float:
    """The largest distance (m) of the particles ``poses`` (P, 3) from their ``weights``-weighted mean position."""
    return float(np.hypot(*(poses[:, :2] - weights @ poses[:, :2]).T).max())


def rows_for(run: LoadedRun, config: SlamConfig, log_name: str, seeds) -> list[dict]:
    """One row per filter, seed and path: sharpness, extent and the run-wide columns (``estimate``);
    with truth ATE and NEES too."""
    tolerance = config.odometry.jump_tolerance
    reckoned = dead_reckoning_without_glitches(run, tolerance)
    # The odometry the grid filter moves by: glitch pairs summed, at each record's own time.
    moved_by = odometry_at_record_times(run.log_with_glitch_pairs_summed(tolerance), run.start_pose)
    rows = []
    for kind in (MapKind.GRID, MapKind.LANDMARKS):
        for seed in seeds:
            paths, run_wide = estimate(run, config, kind, seed)
            sharpness = paths_sharpness(run, {name: poses for name, (poses, _) in paths.items()}, tolerance)
            for path_name, (poses, covariances) in paths.items():
                sharp = sharpness[path_name]
                row = {"log": log_name, "filter": FILTER_NAMES[kind], "seed": seed, "path": path_name}
                row |= {"sharpness_ratio": sharp.ratio, "extent_ratio": sharp.extent_ratio, **run_wide}
                if run.truth is not None:
                    row["ate_rmse_m"] = absolute_trajectory_error(poses, run.truth)["rmse"]
                    row["dead_reckoning_ate_rmse_m"] = absolute_trajectory_error(reckoned, run.truth)["rmse"]
                    row["odometry_ate_rmse_m"] = absolute_trajectory_error(moved_by, run.truth)["rmse"]
                    row["true_extent_ratio"] = path_extent(run.truth) / sharp.dead_reckoning_extent_m
                    if covariances is not None:
                        moved = np.flatnonzero(np.linalg.det(covariances) > 0)  # before the first scan: no spread
                        nees = normalized_estimation_error(poses[moved], covariances[moved], run.truth[moved])
                        row["nees_median"] = nees_summary(nees)["median"]
                rows.append(row)
                pd.DataFrame([row], columns=COLUMNS).to_csv(PARTIAL, mode="a", header=not PARTIAL.exists(), index=False)
                print(row, flush=True)
    return rows


def summary(table: pd.DataFrame) -> pd.DataFrame:
    """Per log, filter and path: the median and the worst (largest) value over the filter seeds."""
    values = [c for c in table.columns if c not in ("log", "filter", "seed", "path")]
    grouped = table.groupby(["log", "filter", "path"], sort=False)[values]
    return grouped.median().add_suffix(" (median)").join(grouped.max().add_suffix(" (worst)"))


def main() -> None:
    config = load_slam_config(COURSE)
    PARTIAL.unlink(missing_ok=True)
    rows = []
    if LOG1.exists():
        run = loaded_with_convention(LOG1, config)
        rows += rows_for(run, config, "log1", FILTER_SEEDS)
    else:
        print(f"{LOG1} is absent: log1 left out", file=sys.stderr)
    folder = HERE / "simulated"
    folder.mkdir(exist_ok=True)
    for seed in SIMULATION_SEEDS:
        path = folder / f"course_sim_{seed}.log"
        simulate(path, load_config(SIMULATION), seed=seed, progress=False)
        rows += rows_for(load_run(path), config, f"simulated seed {seed}", [0])
    PARTIAL.replace(TABLE)
    table = summary(pd.DataFrame(rows))
    (HERE / "filters.md").write_text(table.to_markdown(floatfmt=".3f") + "\n")


if __name__ == "__main__":
    # No options; --help says what the script does (it rewrites its committed results).
    argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter).parse_args()
    main()
