"""What ``mazeslam slam`` writes and prints: trajectory, map, figure, animation, error tables."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from mazeslam import log, sidecars
from mazeslam.beams import BeamGeometry
from mazeslam.config import jsonable
from mazeslam.geometry import transform_points

if TYPE_CHECKING:
    from matplotlib.patches import Ellipse

    from mazeslam.evaluation.slam_view import ScanSource
    from mazeslam.slam import SlamResult

# matplotlib (0.5 s) and the figure modules load when a figure is first drawn, not with the module.


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


def scan_points_world(
    course_log: log.CourseLog,
    poses: np.ndarray,
    geometry: BeamGeometry,
    min_range: float = 0.0,
    max_range: float = np.inf,
) -> np.ndarray:
    """Every scan's returns within [min_range, max_range] (Q, 2), placed in the world by the
    given poses (R, 3) of the records."""
    chunks = [
        transform_points(poses[index], geometry.returns(course_log.values[index], min_range, max_range))
        for index in np.flatnonzero(course_log.is_scan)
    ]
    return np.concatenate(chunks) if chunks else np.empty((0, 2))


@dataclass
class SlamFigure:
    """What the exercise's figure shows, as plain arrays (world frame, metres; picklable, so that
    another process can draw it): the mean path (R, >=2), the particles' poses (P, >=2), the best
    particle's landmarks (L, 2) and their covariances (L, 2, 2), scan points (Q, 2); with truth, the
    true path (R, >=2), walls (W, 4) and true landmarks (K, 2)."""

    mean_poses: np.ndarray
    particles: np.ndarray
    landmarks: np.ndarray
    landmark_covariances: np.ndarray
    points: np.ndarray
    truth: np.ndarray | None = None
    walls: np.ndarray | None = None
    true_landmarks: np.ndarray | None = None
    title: str = ""
    truth_label: str = "true path"

    @classmethod
    def of(cls, result: SlamResult, points: np.ndarray, **rest) -> SlamFigure:
        """The figure of a run: its mean path, final particles and best particle's map."""
        return cls(
            result.mean_poses, result.filter.poses, result.landmarks, result.landmark_covariances, points, **rest
        )


def plot_slam(
    path,
    result: SlamResult,
    points: np.ndarray,
    truth: np.ndarray | None = None,
    walls: np.ndarray | None = None,
    title: str = "",
    true_landmarks: np.ndarray | None = None,
    truth_label: str = "true path",
) -> Path:
    """The exercise's figure of ``result`` (``draw_slam_figure``)."""
    figure = SlamFigure.of(
        result, points, truth=truth, walls=walls, true_landmarks=true_landmarks, title=title, truth_label=truth_label
    )
    return draw_slam_figure(path, figure)


def draw_slam_figure(path, figure: SlamFigure) -> Path:
    """The exercise's figure: best particle's map with 2-sigma ellipses, particles in red, scan
    points in black, the estimated path; with truth, the true path (``truth_label``: a reference
    path is not truth), walls and landmarks too. Drawn on a ``matplotlib.figure.Figure`` (no pyplot:
    no window, and a notebook's backend is left alone), one artist per kind."""
    from matplotlib.figure import Figure

    from mazeslam.evaluation import plots

    fig = Figure(figsize=(9, 7))
    ax = fig.add_subplot()
    plots.draw_walls(ax, figure.walls)
    points = figure.points
    if len(points):  # one rasterised artist: thousands of points cost one image, not thousands of marks
        ax.plot(*points.T, ".", color="black", markersize=0.8, alpha=0.4, label="scan points", rasterized=True)
    truth, true_landmarks = figure.truth, figure.true_landmarks
    if truth is not None:
        ax.plot(truth[:, 0], truth[:, 1], color="tab:green", linewidth=1.2, label=figure.truth_label)
    if true_landmarks is not None and len(true_landmarks):
        ax.plot(
            true_landmarks[:, 0],
            true_landmarks[:, 1],
            "o",
            color="tab:green",
            markersize=4,
            markerfacecolor="none",
            label="true landmarks",
        )
    mean = figure.mean_poses
    ax.plot(mean[:, 0], mean[:, 1], color="tab:blue", linewidth=1.2, label="FastSLAM path")
    ax.plot(figure.particles[:, 0], figure.particles[:, 1], ".", color="red", markersize=3, label="particles")
    landmarks = figure.landmarks
    plots.draw_ellipses(ax, landmarks, figure.landmark_covariances)
    if len(landmarks):
        ax.plot(landmarks[:, 0], landmarks[:, 1], "+", color="tab:purple", markersize=8, label="landmarks (2 sigma)")
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    return plots.save_figure(fig, ax, path, figure.title)


def draw_and_export(
    out_dir, figure: SlamFigure, course_log: log.CourseLog, geometry: BeamGeometry, min_range: float, max_range: float
) -> dict[str, Path]:
    """The outputs that need matplotlib, in one call (``mazeslam slam`` makes it in a side process):
    ``slam.png`` (``draw_slam_figure``) and the map export (``map_export.export_map``: occupancy
    grid along the figure's mean path, scan returns within [min_range, max_range] m, and the
    figure's landmarks). Returns the paths by name, the figure's first."""
    from mazeslam.evaluation.map_export import export_map

    out_dir = Path(out_dir)
    paths = {"figure": draw_slam_figure(out_dir / "slam.png", figure)}
    mean, landmarks, covariances = figure.mean_poses, figure.landmarks, figure.landmark_covariances
    paths.update(export_map(out_dir, course_log, mean, geometry, landmarks, covariances, min_range, max_range))
    return paths


def _ellipse(mean, covariance, sigmas: float = 2.0) -> Ellipse:
    from matplotlib.patches import Ellipse

    values, vectors = np.linalg.eigh(covariance)
    angle = np.degrees(np.arctan2(vectors[1, 1], vectors[0, 1]))
    width, height = 2 * sigmas * np.sqrt(np.maximum(values[::-1], 0))
    return Ellipse(mean, width, height, angle=angle, fill=False, color="tab:purple", linewidth=0.8)


def animate_slam(
    path,
    result: SlamResult,
    points: np.ndarray,
    truth: np.ndarray | None = None,
    walls: np.ndarray | None = None,
    frames_per_second: int = 10,
    scan_at: ScanSource | None = None,
    title: str = "",
    progress: bool = False,
    video: bool | None = None,
    truth_label: str = "true path",
) -> Path:
    """The run as an animation, one frame per snapshot (``SlamView``: particles, map so far, path so
    far, the current scan and its corners from ``scan_at``): MP4 when ffmpeg is available (``path``
    with suffix .mp4), GIF otherwise; returns the path written. A progress bar with ``progress``."""
    from mazeslam.evaluation.slam_view import SlamView, save_animation, view_extent

    extent = view_extent(points, result.mean_poses, truth)
    view = SlamView(result.times, result.mean_poses, extent, title, truth, walls, scan_at, truth_label=truth_label)
    frames = [(index, particles, landmarks) for index, particles, landmarks in result.snapshots]
    return save_animation(view, frames, path, frames_per_second, progress, video)


def write_outputs(out_dir, result: SlamResult, extra: dict) -> dict[str, Path]:
    """``trajectory.csv`` (t,x,y,theta: weighted mean at every record, and the particle cloud's
    covariance cov_xx ... cov_thetatheta), the same as ``trajectory.tum`` (for evo),
    ``best_trajectory.csv`` (most probable particle) and ``map.json`` (best particle's landmarks
    with covariances, run facts; strict JSON)."""
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
    scan_seconds = np.array([s for s in result.step_seconds])
    document = {
        "frame": "world; metres",
        "landmarks": result.landmarks.round(6).tolist(),
        "landmark_covariances": result.landmark_covariances.tolist(),
        "resamplings": result.resamplings,
        "scans": len(result.reports),
        "seconds_total": float(scan_seconds.sum()),
        "seconds_per_record_mean": float(scan_seconds.mean()),
        **extra,
    }
    paths["map"].write_text(json.dumps(jsonable(document), indent=1, allow_nan=False) + "\n")
    return paths
