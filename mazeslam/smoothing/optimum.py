"""The batch optimum of a log beside a filter run: its poses at every record (``optimum_poses``) and the
filter's ATE ratio to it (``optimum_columns``: 1 is as good as any estimator can be), used by
``mazeslam slam``, sweeps and ``mazeslam smooth``. A corner config's optimum is the known-association
smoother of corners and poses (``known_optimum``); a grid config's, the pose graph of the scans with
loop closures (``mazeslam.smoothing.laser_optimum``).

Association comes from outside the smoother: the truth's corners (``truth_identities``) or a
finished ``mazeslam slam`` run's map (``from_run_identities``). Noise: the config's ``[fastslam]``
settings (the filter's own model), corners by its ``[corners]``; odometry records the filter leaves
out as glitches (``[odometry] jump_tolerance``) move nothing here either.
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mazeslam.core.config import InputError, read_text
from mazeslam.data import sidecars
from mazeslam.data.loaded_run import LoadedRun
from mazeslam.evaluation.scoring import RunScore, error_rows
from mazeslam.fastslam.identities import identities_along, truth_identities
from mazeslam.features.corners import CornerExtractor
from mazeslam.pipeline.config import MapKind, SlamConfig
from mazeslam.smoothing.laser_optimum import has_laser_optimum, smooth_laser_run
from mazeslam.smoothing.smoother import SmoothingResult, expand_to_records, smooth_known_association

#: The optimum's row in error tables.
OPTIMUM = "batch optimum"


@dataclass(kw_only=True)
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
    if not run.log.scans_only:
        raise ValueError(f"{run.path}: the smoother needs a log of scans (and no landmark records)")
    started = time.perf_counter()
    course_log = run.log_without_glitches(config.odometry.jump_tolerance)
    extractor = CornerExtractor(run.geometry, course_log.width, config.corners)
    result = smooth_known_association(course_log, extractor, identify, config.fastslam, run.start_pose)
    poses = expand_to_records(course_log, result, run.start_pose)
    anchor = np.searchsorted(result.scan_records, np.arange(len(course_log)), side="right") - 1
    covariances = result.pose_covariances[np.maximum(anchor, 0)]
    return Smoothed(result=result, poses=poses, covariances=covariances, seconds=time.perf_counter() - started)


def has_known_optimum(run: LoadedRun) -> bool:
    """The run can be smoothed with known association: truth, true corners and a log of scans."""
    return run.truth is not None and len(run.true_corners) > 0 and run.log.scans_only


def known_optimum(run: LoadedRun, config: SlamConfig) -> Smoothed:
    """The optimum of ``run`` with the true corners as association (``has_known_optimum`` must hold)."""
    return smooth_run(run, config, truth_identities(run, config.evaluation.match_radius))


def has_optimum(run: LoadedRun, config: SlamConfig) -> bool:
    """``run`` has an optimum to score ``config``'s filter against: the pose graph of its scans
    (``has_laser_optimum``) for a grid, the known-association smoother (``has_known_optimum``) for corners."""
    return has_laser_optimum(run) if config.map.kind == MapKind.GRID else has_known_optimum(run)


def optimum_poses(run: LoadedRun, config: SlamConfig) -> np.ndarray:
    """The optimum's poses (R, 3) at every record of ``run`` for ``config``'s filter (``has_optimum``
    must hold): the pose graph's (``smooth_laser_run``) or the known-association smoother's."""
    if config.map.kind == MapKind.GRID:
        return smooth_laser_run(run, config).poses
    return known_optimum(run, config).poses


def optimum_columns(
    run: LoadedRun, config: SlamConfig, score: RunScore, poses: np.ndarray | None = None
) -> dict | None:
    """The optimum's ATE RMSE (m, as estimated and aligned) at the records the filter was scored at
    (``score.records``) and the filter's ratio to it (``optimum_ratio``, ``optimum_aligned_ratio``: 1
    is as good as any estimator can be; NaN where the optimum has no error, as on a log of one pose);
    None without ``has_optimum``. ``poses``: ``optimum_poses(run, config)`` (R, 3) if already
    computed (a sweep computes them once for the runs that share a log and the settings they depend on)."""
    if run.truth is None or not has_optimum(run, config):
        return None
    if poses is None:
        poses = optimum_poses(run, config)
    poses, truth = poses[score.records], run.truth[score.records]
    row = error_rows({OPTIMUM: poses}, truth)[OPTIMUM]
    return {
        "optimum_ate_rmse": row["ate_rmse"],
        "optimum_ate_aligned_rmse": row["aligned_rmse"],
        "optimum_ratio": _ratio(score.ate(), row["ate_rmse"]),
        "optimum_aligned_ratio": _ratio(score.ate(aligned=True), row["aligned_rmse"]),
    }


#: Metres: an optimum's ATE at or below this is no error (rounding; the log holds 1e-6), and a ratio to
#: it is undefined.
NO_ERROR = 1e-9


def _ratio(error: float, optimum: float) -> float:
    """A filter's error over the optimum's; NaN (undefined) where the optimum has no error (a log of
    one pose, or one the observations pin down exactly)."""
    return error / optimum if optimum > NO_ERROR else math.nan


def optimum_line(columns: dict, filter_name: str = "FastSLAM") -> str:
    """``optimum_columns`` as one line for ``mazeslam slam`` (the filter named ``filter_name``: the
    grid filter's optimum is the pose graph of the scans, FastSLAM's the corners smoothed with its noise)."""
    ratio, aligned = (
        "undefined" if math.isnan(columns[key]) else f"{columns[key]:.2f}"
        for key in ("optimum_ratio", "optimum_aligned_ratio")
    )
    what = "pose graph of the scans, loop closures" if filter_name == "grid filter" else "known association"
    return (
        f"Batch optimum ({what}): ATE {columns['optimum_ate_rmse']:.4f} m "
        f"(aligned {columns['optimum_ate_aligned_rmse']:.4f} m); {filter_name}/optimum ratio {ratio} (aligned "
        f"{aligned})" + (": the optimum has no error" if "undefined" in (ratio, aligned) else "")
    )


def smoothed_poses(run: LoadedRun, folder: str | Path) -> np.ndarray | None:
    """The poses (R, 3) at every record of ``run`` that a ``mazeslam smooth`` of the same log wrote into
    ``folder`` (its trajectory.csv), None when the folder holds no smooth run; an error when it holds
    the run of another log (its map.json's ``source``, or a record count that differs)."""
    folder = Path(folder)
    trajectory, document = folder / "trajectory.csv", folder / "map.json"
    if not (trajectory.is_file() and document.is_file()):
        return None
    try:
        source = json.loads(read_text(document, "map"))["source"]
    except (json.JSONDecodeError, KeyError, TypeError) as error:
        raise ValueError(f"{document}: not the map.json of a `mazeslam smooth` run (no 'source')") from error
    if Path(source).resolve() != run.path.resolve():
        raise ValueError(f"{folder}: the smooth run of {source}, not of {run.path}")
    return _poses_of_every_record(run, trajectory)


def _poses_of_every_record(run: LoadedRun, trajectory: Path) -> np.ndarray:
    """The poses (R, 3) of the trajectory CSV ``trajectory``, one per record of ``run``'s log (an
    error naming it when the count differs: a run of another log)."""
    poses = sidecars.read_trajectory(trajectory)[1]
    if len(poses) != len(run.log):
        raise ValueError(
            f"{trajectory}: {len(poses)} poses for the {len(run.log)} records of {run.path}: a run of another log?"
        )
    return poses


def from_run_identities(run: LoadedRun, run_dir: str | Path, radius: float):
    """``map_identities`` of a `mazeslam slam` output folder: its mean path (``run_dir``/trajectory.csv)
    and final map (``run_dir``/map.json)."""
    run_dir = Path(run_dir)
    paths = [run_dir / "trajectory.csv", run_dir / "map.json"]
    missing = [str(p) for p in paths if not p.exists()]
    if missing:
        raise ValueError(f"{run_dir}: not a `mazeslam slam` output folder, missing {', '.join(missing)}")
    poses = _poses_of_every_record(run, paths[0])
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
