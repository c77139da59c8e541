"""Corner FastSLAM on the 8 CARMEN building logs: import, map, score against the reference poses.

    python -m experiments.carmen.run [--seeds 5] [--workers 2] [--logs aces ...]   (about 15 minutes on 2 cores)

For each log: ``mazeslam import carmen`` then corner FastSLAM with configs/carmen.toml's ``[fastslam]``
and ``[corners]`` (its ``[map] kind`` set to "landmarks"; one setting for the family: laser odometry,
FastSLAM 2.0, 100 particles) under ``--seeds`` filter seeds. Scored at
the scans against the reference poses (gmapping's corrected poses: a reference, not ground truth;
the log has no other pose to score against): the ATE of the wheel odometry, of the laser odometry
alone and of FastSLAM (median and worst over the seeds), with and without SE(2) alignment; the
pose NEES of the mean path against the reference with the cloud's covariance (the reference's own
errors count as the filter's) and the mean NIS of the corner observations (2 degrees of freedom:
2 when the noise is stated right), medians over the seeds; landmarks, run time, particles
(results/table.csv and table.md; a run with --logs keeps the other logs' rows); per seed the ATE,
aligned ATE, the relation metric (Kümmerle et al. 2009), NEES and NIS (results/seeds.csv).
Figures in docs/img/carmen/: the median seed's map drawn over the scans, and its scans beside the
picture of the map that comes with the log.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from mazeslam.core.config import with_settings  # noqa: E402
from mazeslam.core.motion import dead_reckoning  # noqa: E402
from mazeslam.data.carmen import import_carmen  # noqa: E402
from mazeslam.data.loaded_run import LoadedRun, load_run  # noqa: E402
from mazeslam.data.scans import scan_points_world  # noqa: E402
from mazeslam.evaluation.consistency import nees_summary, nis_summary  # noqa: E402
from mazeslam.evaluation.metrics import absolute_trajectory_error, normalized_estimation_error  # noqa: E402
from mazeslam.evaluation.relations import BUILDING_RADIUS, relation_metric, spatial_relations  # noqa: E402
from mazeslam.pipeline import SlamConfig, load_slam_config, run_slam  # noqa: E402
from mazeslam.registration.scan_matching import LaserOdometry, laser_odometry  # noqa: E402
from mazeslam.sweeps.pool import map_parallel  # noqa: E402
from mazeslam.viz import slam_figure as slam_report  # noqa: E402

HERE = Path(__file__).resolve().parent
PROJECT = HERE.parents[1]
DATA = PROJECT.parent / "shared" / "data" / "carmen"
CONFIG = PROJECT / "configs" / "carmen.toml"
FIGURES = PROJECT / "docs" / "img" / "carmen"
LOGS = ["aces", "csail", "edmonton", "fhw", "freiburg-079", "freiburg-101", "orebro", "seattle"]


def ate(poses: np.ndarray, reference: np.ndarray) -> tuple[float, float]:
    """ATE RMSE (m) as estimated and after the best SE(2) alignment."""
    return (
        absolute_trajectory_error(poses, reference)["rmse"],
        absolute_trajectory_error(poses, reference, align=True)["rmse"],
    )


def run_one(
    run: LoadedRun, config: SlamConfig, seed: int, laser: LaserOdometry, reference: np.ndarray, scans: np.ndarray
) -> dict:
    """FastSLAM on one imported log with one filter seed, moving by the log's laser odometry
    ``laser``: its errors at the scans (``reference`` poses at the ``scans`` records), and the result."""
    began = time.perf_counter()
    result = run_slam(run, config.with_seed(seed), progress=False, laser=laser)
    seconds = time.perf_counter() - began
    raw, aligned = ate(result.mean_poses[scans], reference[scans])
    relations = relation_metric(
        result.mean_poses[scans], reference[scans], spatial_relations(reference[scans], BUILDING_RADIUS)
    )
    nees = nees_summary(
        normalized_estimation_error(result.mean_poses[scans], result.pose_covariances[scans], reference[scans])
    )
    nis = nis_summary(result.nis)
    return {
        "seed": seed,
        "ate": raw,
        "aligned": aligned,
        "rel_trans_m": relations["trans_mean"],
        "rel_rot_deg": float(np.degrees(relations["rot_mean"])),
        "nees_median": nees["median"],
        "nees_inside_95": nees["inside_95"],
        "nis_mean": nis["mean"],
        "nis_inside_95": nis["inside_95"],
        "seconds": seconds,
        "landmarks": len(result.landmarks),
        "result": result,
    }


def evaluate(name: str, seeds: int, out: Path) -> tuple[dict, list[dict]]:
    """Import one building, match its scans once, run every seed, draw the median seed's map; the
    table row and a row per seed (aligned ATE and the relation metric over the pairs of scans
    within ``BUILDING_RADIUS`` of each other by the reference, for results/seeds.csv)."""
    course = out / f"{name}.log"
    import_carmen(DATA / f"{name}-corrected.log.gz", course)
    config = with_settings(load_slam_config(CONFIG), {"map.kind": "landmarks"})  # corner FastSLAM, not the grid
    run = load_run(course)
    course_log, reference, start = run.log, run.truth, run.start_pose
    scans = np.flatnonzero(course_log.is_scan)
    began = time.perf_counter()
    laser = laser_odometry(course_log, run.geometry, config.scan_matching)
    matching_seconds = time.perf_counter() - began
    runs = sorted(
        (run_one(run, config, seed, laser, reference, scans) for seed in range(seeds)), key=lambda run: run["ate"]
    )
    median = runs[len(runs) // 2]
    row = {"log": name, "scans": len(scans), "particles": config.fastslam.NPARTICLES}
    reckoned = dead_reckoning(course_log, start)[scans]
    row["odometry ATE [m]"], row["odometry aligned [m]"] = ate(reckoned, reference[scans])
    row["laser odometry ATE [m]"], row["laser odometry aligned [m]"] = ate(laser.poses(start), reference[scans])
    row["FastSLAM ATE [m] (median)"] = float(np.median([run["ate"] for run in runs]))
    row["FastSLAM ATE [m] (worst)"] = runs[-1]["ate"]
    row["FastSLAM aligned [m] (median)"] = float(np.median([run["aligned"] for run in runs]))
    row["NEES (median)"] = float(np.median([run["nees_median"] for run in runs]))
    row["NIS mean (median)"] = float(np.median([run["nis_mean"] for run in runs]))
    row["landmarks"] = median["landmarks"]
    row["FastSLAM s"] = matching_seconds + float(np.median([run["seconds"] for run in runs]))
    points = scan_points_world(course_log, median["result"].mean_poses, run.geometry, 0.1, config.corners.max_range)
    title = f"{name}: FastSLAM on laser odometry (filter seed {median['seed']}, the median of {seeds})"
    slam_report.plot_slam(
        FIGURES / f"{name}.png",
        median["result"],
        points[::5],
        reference[scans],
        None,
        title=title,
        truth_label="reference path (gmapping)",
    )
    beside_the_reference_picture(FIGURES / f"{name}_vs_reference.png", points, DATA / f"{name}-corrected.png", name)
    for suffix in (".log", ".truth.csv", ".map.json"):
        course.with_name(course.stem + suffix).unlink()
    print({k: round(v, 2) if isinstance(v, float) else v for k, v in row.items()}, flush=True)
    seed_rows = [{"log": name, **{key: value for key, value in run.items() if key != "result"}} for run in runs]
    return row, seed_rows


def beside_the_reference_picture(path: Path, points: np.ndarray, picture: Path, name: str) -> None:
    """Our scans, placed by FastSLAM, beside the map picture that comes with the log."""
    fig, (ours, theirs) = plt.subplots(1, 2, figsize=(11, 5.5), layout="constrained")
    ours.plot(points[:, 0], points[:, 1], ",", color="black", alpha=0.5, label="laser returns, placed by FastSLAM")
    ours.set_aspect("equal")
    ours.set_title(f"{name}: scans placed by FastSLAM (corner map)")
    ours.set_xlabel("x [m]")
    ours.set_ylabel("y [m]")
    ours.legend(loc="upper left", fontsize=8, markerscale=20)
    theirs.imshow(plt.imread(picture), cmap="gray")
    theirs.set_title("the map picture that comes with the log (no scale)")
    theirs.axis("off")
    fig.savefig(path, dpi=90)
    plt.close(fig)


def merged(path: Path, table: pd.DataFrame, keys: list[str]) -> pd.DataFrame:
    """``table`` with the rows of the CSV at ``path`` whose ``keys`` it does not hold (other logs)."""
    if path.exists():
        old = pd.read_csv(path)
        keep = ~old.set_index(keys).index.isin(table.set_index(keys).index)
        table = pd.concat([old[keep], table])
    return table.sort_values(keys)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=5, help="filter seeds per log")
    parser.add_argument("--workers", type=int, default=2, help="logs processed at once")
    parser.add_argument("--logs", nargs="+", default=LOGS, choices=LOGS, help="logs to run (others' rows are kept)")
    args = parser.parse_args()
    out = HERE / "results"
    out.mkdir(exist_ok=True)
    FIGURES.mkdir(parents=True, exist_ok=True)
    results = map_parallel(evaluate, [(name, args.seeds, out) for name in args.logs], args.workers)
    seeds = merged(out / "seeds.csv", pd.DataFrame([row for _, rows in results for row in rows]), ["log", "seed"])
    seeds.to_csv(out / "seeds.csv", index=False, float_format="%.4g")
    table = merged(out / "table.csv", pd.DataFrame([row for row, _ in results]), ["log"])
    table.to_csv(out / "table.csv", index=False, float_format="%.4g")
    markdown = table.to_markdown(index=False, floatfmt=".2f")
    (out / "table.md").write_text(markdown + "\n")
    print(markdown)


if __name__ == "__main__":
    main()
