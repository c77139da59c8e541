"""What a SLAM run writes, for both filters: trajectories, the map and the run's facts.

Files in the run's folder (``write_outputs``): ``trajectory.csv`` (the cloud's weighted mean at
every record with its covariance) and ``trajectory.tum`` (the same for evo), ``best_trajectory.csv``
(the best particle's path), ``map.json`` (run facts, the landmarks with covariances or the grid's
summary, the errors with truth; strict JSON), ``truth.tum`` beside a truth; a grid run also
``occupancy.pgm`` + ``occupancy.yaml`` (ROS map_server). Figures (``slam.png``, ``occupancy.png``)
and animations are drawn by ``mazeslam.viz``.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from mazeslam.core.outputs import write_json
from mazeslam.data import sidecars

if TYPE_CHECKING:
    from mazeslam.pipeline.result import SlamResult


def consistency(result: SlamResult) -> dict:
    """Checks that need no truth: how often the best particle's landmarks were re-observed, how
    close its two nearest landmarks are (duplicates sit close), the largest jump of the path."""
    slam = result.filter
    best = slam.best_particle()
    seen = slam.seen[best][slam.exists[best]]
    landmarks = result.landmarks
    if len(landmarks) > 1:
        gaps = np.hypot(*(landmarks[:, None, :] - landmarks[None]).transpose(2, 0, 1))
        nearest = float(gaps[~np.eye(len(landmarks), dtype=bool)].min())
    else:
        nearest = float("nan")
    steps = np.hypot(*np.diff(result.mean_poses[:, :2], axis=0).T) if len(result.mean_poses) > 1 else np.zeros(1)
    return {
        "landmarks": len(landmarks),
        "reobserved": int((seen >= 2).sum()),
        "median_observations": float(np.median(seen)) if len(seen) else 0.0,
        "nearest_landmarks_m": nearest,
        "largest_path_step_m": float(steps.max()),
    }


def write_outputs(out_dir, result: SlamResult, extra: dict) -> dict[str, Path]:
    """Write the run's files into ``out_dir`` (created): ``trajectory.csv`` (t, x, y, theta: the
    weighted mean at every record, and the particle cloud's covariance cov_xx ... cov_thetatheta),
    the same as ``trajectory.tum`` (for evo), ``best_trajectory.csv`` (the best particle's path),
    for a grid ``occupancy.pgm/.yaml/.png`` (the best particle's map), and ``map.json``: the run's
    facts, the landmarks with their covariances (for a grid, its size and memory), and ``extra``
    (strict JSON). Each file is written whole or not at all (``mazeslam.core.outputs.written``: a
    ``WriteError`` names the file that could not be written). Returns the paths by name."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = {
        "trajectory": out_dir / "trajectory.csv",
        "best_trajectory": out_dir / "best_trajectory.csv",
        "map": out_dir / "map.json",
        "tum": out_dir / "trajectory.tum",
    }
    sidecars.write_trajectory(paths["trajectory"], result.times, result.mean_poses, result.pose_covariances)
    sidecars.write_tum(paths["tum"], result.times, result.mean_poses)
    sidecars.write_truth(paths["best_trajectory"], result.times, result.best_poses)
    document = {
        "kind": str(result.kind),
        "frame": "world; metres",
        "resamplings": result.resamplings,
        "updates": result.updates,
        "scans": len(result.reports) if result.grid is None else len(result.estimated_records),
        "seconds_total": float(result.step_seconds.sum()),
        "seconds_per_record_mean": float(result.step_seconds.mean()) if len(result.step_seconds) else 0.0,
    }
    if result.grid is not None:
        from mazeslam.data.map_io import write_map

        assert result.grid_run is not None and result.occupancy is not None
        paths["occupancy"] = write_map(result.occupancy, out_dir)
        document.update(
            occupancy=paths["occupancy"].name,
            seconds_total=result.grid_run.total_seconds,
            processed_scans=int(result.grid_run.processed.sum()),
            peak_map_bytes=result.grid_run.peak_map_bytes,
        )
    else:
        document.update(
            landmarks=result.landmarks.round(6).tolist(), landmark_covariances=result.landmark_covariances.tolist()
        )
    document.update(extra)
    write_json(paths["map"], document)
    return paths
