"""``mazeslam smooth``: the batch least-squares optimum of a log (``filters/smoother.py``), its outputs,
and the optimum beside a FastSLAM run (``mazeslam slam`` and sweeps report the filter's ratio to it).

Association, which landmark each corner is, comes from outside the smoother:

* ``known``: the true corner within ``[evaluation] match_radius`` of where the true pose puts the
  observation (``slam.truth_identities``); simulated and referenced logs with a map of corners;
* ``from-run``: a FastSLAM run's final map. Each scan's corners are placed in the world by the run's
  mean pose at that scan (``trajectory.csv``) and named by the nearest landmark of its ``map.json``
  within ``match_radius``; farther ones are left out. This re-associates after the fact: the filter's
  own choices are not saved, the map is the best particle's at the end, and the mean path is not that
  particle's history, so an observation made before a loop closed can fall to a neighbouring landmark
  or outside the radius.

Noise: the config's ``[fastslam]`` settings (the filter's own model), corners by its ``[corners]``;
odometry records the filter leaves out as glitches (``[odometry] jump_tolerance``) move nothing here either.
"""

from __future__ import annotations

import dataclasses
import json
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mazeslam import sidecars
from mazeslam.beam_detection import with_detected_convention
from mazeslam.beams import SensorOverrides
from mazeslam.config import InputError, jsonable, read_text
from mazeslam.evaluation.consistency import nees_summary
from mazeslam.evaluation.metrics import (
    align_se2,
    apply_se2,
    map_error,
    normalized_estimation_error,
)
from mazeslam.evaluation.scoring import DEAD_RECKONING, RunScore, error_rows, error_table
from mazeslam.evaluation.slam_report import _ellipse, scan_points_world
from mazeslam.filters.corners import CornerExtractor
from mazeslam.filters.motion import dead_reckoning
from mazeslam.filters.smoother import (
    SmoothingResult,
    expand_to_records,
    smooth_known_association,
)
from mazeslam.loaded_run import LoadedRun, load_run
from mazeslam.slam import SlamConfig, identities_along, load_slam_config, truth_identities

#: The optimum's row in error tables.
OPTIMUM = "batch optimum"


@dataclass
class Smoothed:
    """The optimum of a log and its poses at every record.

    Attributes:
        result: the optimum at the scans (poses, covariances, landmarks, chi2, ...).
        poses: (R, 3) pose at every record (``expand_to_records``), world frame, m and rad.
        covariances: (R, 3, 3) at scan records the optimum's; at other records the previous scan's
            (the first scan's before it): the odometry since the scan is not added.
        seconds: wall-clock time of extraction and solving.
    """

    result: SmoothingResult
    poses: np.ndarray
    covariances: np.ndarray
    seconds: float


def smooth_run(run: LoadedRun, config: SlamConfig, identify) -> Smoothed:
    """The optimum of ``run``'s scans with ``identify(record_index, observations (K, 2)) -> ids (K,)``
    naming the corners (-1: left out), the filter's noise (``config.fastslam``) and corners (``config.corners``)."""
    if not run.log.is_scan.any() or run.log.is_landmark.any():
        raise ValueError(f"{run.path}: the smoother needs a log of scans (and no landmark records)")
    started = time.perf_counter()
    course_log = run.log_without_glitches(config.odometry.jump_tolerance)
    extractor = CornerExtractor(run.geometry, course_log.width, config.corners)
    result = smooth_known_association(course_log, extractor, identify, config.fastslam, run.start_pose)
    poses = expand_to_records(course_log, result, run.start_pose)
    anchor = np.searchsorted(result.scan_records, np.arange(len(course_log)), side="right") - 1
    covariances = result.pose_covariances[np.maximum(anchor, 0)]
    return Smoothed(result, poses, covariances, time.perf_counter() - started)


def has_known_optimum(run: LoadedRun) -> bool:
    """The run can be smoothed with known association: truth, true corners and a log of scans."""
    return (
        run.truth is not None
        and len(run.true_corners) > 0
        and bool(run.log.is_scan.any())
        and not run.log.is_landmark.any()
    )


def known_optimum(run: LoadedRun, config: SlamConfig) -> Smoothed:
    """The optimum of ``run`` with the true corners as association (``has_known_optimum`` must hold)."""
    return smooth_run(run, config, truth_identities(run, config.evaluation.match_radius))


def optimum_columns(
    run: LoadedRun, config: SlamConfig, score: RunScore, optimum_poses: np.ndarray | None = None
) -> dict | None:
    """The known-association optimum's ATE RMSE (m, as estimated and aligned) at the records the filter
    was scored at (``score.records``) and the filter's ratio to it (``optimum_ratio``,
    ``optimum_aligned_ratio``: 1 is as good as any estimator can be); None without ``has_known_optimum``.
    ``optimum_poses``: ``known_optimum(run, config).poses`` (R, 3) if already computed (a sweep computes
    it once for the runs that share a log and the settings it depends on)."""
    if run.truth is None or not has_known_optimum(run):
        return None
    if optimum_poses is None:
        optimum_poses = known_optimum(run, config).poses
    poses, truth = optimum_poses[score.records], run.truth[score.records]
    row = error_rows({OPTIMUM: poses}, truth)[OPTIMUM]
    return {
        "optimum_ate_rmse": row["ate_rmse"],
        "optimum_ate_aligned_rmse": row["aligned_rmse"],
        "optimum_ratio": score.ate() / row["ate_rmse"],
        "optimum_aligned_ratio": score.ate(aligned=True) / row["aligned_rmse"],
    }


def optimum_line(columns: dict) -> str:
    """``optimum_columns`` as one line for ``mazeslam slam``."""
    return (
        f"Batch optimum (known association, the filter's noise): ATE {columns['optimum_ate_rmse']:.4f} m "
        f"(aligned {columns['optimum_ate_aligned_rmse']:.4f} m); FastSLAM/optimum ratio "
        f"{columns['optimum_ratio']:.2f} (aligned {columns['optimum_aligned_ratio']:.2f})"
    )


def from_run_identities(run: LoadedRun, run_dir: str | Path, radius: float):
    """``map_identities`` of a `mazeslam slam` output folder: its mean path (``run_dir``/trajectory.csv)
    and final map (``run_dir``/map.json)."""
    run_dir = Path(run_dir)
    paths = [run_dir / "trajectory.csv", run_dir / "map.json"]
    missing = [str(p) for p in paths if not p.exists()]
    if missing:
        raise ValueError(f"{run_dir}: not a `mazeslam slam` output folder, missing {', '.join(missing)}")
    poses = sidecars.read_trajectory(paths[0])[1]
    if len(poses) != len(run.log):
        raise ValueError(
            f"{paths[0]}: {len(poses)} poses for the {len(run.log)} records of {run.path}: a run of another log?"
        )
    try:
        landmarks = np.asarray(json.loads(read_text(paths[1], "map"))["landmarks"], dtype=float).reshape(-1, 2)
    except (json.JSONDecodeError, KeyError, TypeError, ValueError) as error:
        if isinstance(error, InputError):
            raise
        raise ValueError(f"{paths[1]}: not the map of a `mazeslam slam` run (a 'landmarks' list of [x, y])") from error
    if not np.isfinite(landmarks).all():
        raise ValueError(f"{paths[1]}: a landmark is not finite")
    return map_identities(run, poses, landmarks, radius)


def map_identities(run: LoadedRun, poses: np.ndarray, landmarks, radius: float):
    """``identify`` naming each observation by the nearest of a filter's ``landmarks`` (L, 2) within
    ``radius`` metres of where the filter's pose at that record (``poses`` (R, 3)) puts it; -1 if none.
    Ids are indices into ``landmarks``."""
    return identities_along(np.asarray(poses), np.asarray(landmarks, dtype=float).reshape(-1, 2), radius)


def run_smooth_command(
    log_file, config_path, out_dir, association: str = "known", run_dir=None, sensor: SensorOverrides | None = None
) -> list[str]:
    """Smooth, write ``out_dir``/{trajectory.csv, trajectory.tum, map.json, smooth.png}; return the
    lines to print. ``association``: "known" (the truth's corners) or "from-run" (``run_dir``'s map)."""
    config = load_slam_config(config_path)
    config = dataclasses.replace(config, sensor=(sensor or SensorOverrides()).over(config.sensor))
    run = load_run(log_file, config.sensor)
    run = with_detected_convention(run, config, cache_folder=Path(out_dir))
    radius = config.evaluation.match_radius
    if association == "known":
        if run.truth is None or not len(run.true_corners):
            raise ValueError(
                f"{run.path}: --association known needs the truth and map sidecars with the true corners "
                f"({run.name}.truth.csv, {run.name}.map.json); use --association from-run RUN_DIR"
            )
        identify, how = truth_identities(run, radius), f"known: the true corner within {radius:g} m"
    else:
        identify = from_run_identities(run, run_dir, radius)
        how = f"from the run {run_dir}: its map's nearest landmark within {radius:g} m"
    smoothed = smooth_run(run, config, identify)
    result = smoothed.result
    lines = [
        (
            f"{run.path}: {len(result.poses)} scan poses, {len(result.landmarks)} landmarks, "
            f"association {how}; beam geometry from {run.geometry_origin}"
        ),
        (
            f"Batch optimum: {result.iterations} iterations "
            f"({'converged' if result.converged else 'NOT converged'}), "
            f"{smoothed.seconds:.2f} s; chi2 {result.chi2:.1f} over {result.dof} degrees of freedom, chi2/dof "
            f"{result.chi2_per_dof:.2f} (1: the noise model fits the residuals; below: it overstates the noise)"
        ),
    ]
    document = {
        "frame": "world; metres",
        "source": str(log_file),
        "association": how,
        "landmark_ids": result.landmark_ids.tolist(),
        "landmarks": result.landmarks.round(6).tolist(),
        "landmark_covariances": result.landmark_covariances.tolist(),
        "chi2": result.chi2,
        "dof": result.dof,
        "chi2_per_dof": result.chi2_per_dof,
        "iterations": result.iterations,
        "converged": result.converged,
        "scans": len(result.poses),
        "seconds": smoothed.seconds,
        "parameters": dataclasses.asdict(config),
    }
    if run.truth is not None:
        errors, error_lines = _errors(run, run.truth, smoothed, radius)
        document.update(errors)
        lines += error_lines
    else:
        lines.append("no ground truth beside the log: no errors to report")
    paths = _write_outputs(Path(out_dir), run, config, smoothed, document)
    lines.append("wrote " + ", ".join(str(p) for p in paths.values()))
    return lines


def _errors(run: LoadedRun, truth: np.ndarray, smoothed: Smoothed, radius: float) -> tuple[dict, list[str]]:
    """ATE at every record against dead reckoning, NEES at the scans, map errors against ``truth``
    (``run.truth``): for map.json and to print."""
    result = smoothed.result
    table = error_table({DEAD_RECKONING: dead_reckoning(run.log, run.start_pose), OPTIMUM: smoothed.poses}, truth)
    nees = nees_summary(normalized_estimation_error(result.poses, result.pose_covariances, truth[result.scan_records]))
    aligned = (
        apply_se2(align_se2(smoothed.poses, truth), result.landmarks) if len(result.landmarks) else result.landmarks
    )
    map_errors = {
        "as estimated": map_error(result.landmarks, run.true_corners, radius),
        "aligned": map_error(aligned, run.true_corners, radius),
    }
    lines = [
        (
            f"Errors against {run.truth_label} at every record: ATE [m] (aligned: after the best rigid motion), "
            "RPE [m, rad]:"
        ),
        table.to_markdown(floatfmt=".4f"),
        f"Pose NEES at the {nees['count']} scans (consistent: 3): "
        + (
            f"mean {nees['mean']:.2f}, median {nees['median']:.2f}, "
            f"{100 * nees['inside_95']:.0f} % inside the 95 % bound"
            if nees["count"]
            else "undefined"
        ),
    ]
    if len(run.true_corners):
        errors = map_errors["as estimated"]
        lines.append(
            f"Map: {errors['matched']} landmarks within {radius:g} m of a true one, "
            f"RMSE {errors['rmse']:.4f} m (aligned {map_errors['aligned']['rmse']:.4f} m)"
        )
    return {"ate": table.reset_index().to_dict(orient="records"), "nees": nees, "map_error": map_errors}, lines


def _write_outputs(out_dir: Path, run: LoadedRun, config: SlamConfig, smoothed: Smoothed, document: dict) -> dict:
    """trajectory.csv (with covariances), trajectory.tum, map.json (strict JSON) and smooth.png."""
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = {"trajectory": out_dir / "trajectory.csv", "tum": out_dir / "trajectory.tum", "map": out_dir / "map.json"}
    sidecars.write_trajectory(paths["trajectory"], run.log.times, smoothed.poses, smoothed.covariances)
    sidecars.write_tum(paths["tum"], run.log.times, smoothed.poses)
    paths["map"].write_text(json.dumps(jsonable(document), indent=1, allow_nan=False) + "\n")
    points = scan_points_world(
        run.log, smoothed.poses, run.geometry, config.corners.min_range, config.corners.max_range
    )
    paths["figure"] = plot_smoothed(out_dir / "smooth.png", run, smoothed, points)
    return paths


def plot_smoothed(path, run: LoadedRun, smoothed: Smoothed, points: np.ndarray) -> Path:
    """The slam figure for the optimum: its map with 2-sigma ellipses, scan points placed by its poses,
    its path beside dead reckoning; with the sidecars, the walls, true path and true corners."""
    import matplotlib.pyplot as plt  # here: the slam command imports this module, and draws without pyplot

    from mazeslam.evaluation.plots import save_figure

    fig, ax = plt.subplots(figsize=(9, 7))
    for x1, y1, x2, y2 in run.walls if run.walls is not None else []:
        ax.plot([x1, x2], [y1, y2], color="0.6", linewidth=1.0)
    if len(points):
        ax.plot(*points.T, ".", color="black", markersize=0.8, alpha=0.4, label="scan points")
    paths = {
        "dead reckoning": (dead_reckoning(run.log, run.start_pose), "0.5"),
        "batch optimum": (smoothed.poses, "tab:blue"),
    }
    if run.truth is not None:
        paths["reference path" if run.truth_is_reference else "true path"] = (run.truth, "tab:green")
    for label, (poses, colour) in paths.items():
        ax.plot(poses[:, 0], poses[:, 1], color=colour, linewidth=1.2, label=label)
    if len(run.true_corners):
        ax.plot(
            *run.true_corners.T, "o", color="tab:green", markersize=4, markerfacecolor="none", label="true landmarks"
        )
    result = smoothed.result
    for mean, covariance in zip(result.landmarks, result.landmark_covariances):
        ax.add_patch(_ellipse(mean, covariance))
    if len(result.landmarks):
        ax.plot(*result.landmarks.T, "+", color="tab:purple", markersize=8, label="landmarks (2 sigma)")
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    title = f"{run.path.name}: batch optimum, chi2/dof {result.chi2_per_dof:.2f}"
    return save_figure(fig, ax, path, title)
