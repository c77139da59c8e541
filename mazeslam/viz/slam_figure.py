"""Corner FastSLAM's figures: the exercise's map figure (``slam.png``) and the run's animation."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from mazeslam.core.beams import BeamGeometry
from mazeslam.data import log

if TYPE_CHECKING:
    from mazeslam.pipeline.result import SlamResult
    from mazeslam.viz.slam_view import ScanSource

# matplotlib (0.5 s) and the figure modules load when a figure is first drawn, not with the module.


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

    from mazeslam.viz import plots

    fig = Figure(figsize=(9, 7))
    ax = fig.add_subplot()
    points = figure.points
    # faint under walls, which they must not hide; without walls (a real log) the points are the map
    faint = 0.15 if figure.walls is not None and len(figure.walls) else 0.3
    if len(points):  # one rasterised artist: thousands of points cost one image, not thousands of marks
        ax.plot(
            *points.T, ".", color="black", markersize=0.6, alpha=faint, label="scan points", rasterized=True, zorder=1
        )
    plots.draw_walls(ax, figure.walls, colour="tab:brown", linewidth=1.2)  # over the points: they do not hide it
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
    plots.mark_start(ax, mean, "tab:blue")
    particles = figure.particles  # they gather where the path ends: the end is an outline drawn over them
    ax.plot(particles[:, 0], particles[:, 1], ".", color="red", markersize=3, label="particles", zorder=5)
    plots.mark_end(ax, mean, "tab:blue")
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
    figure's landmarks) with the grid's ``occupancy.png`` (``plot_occupancy``). Returns the paths by
    name, the figure's first."""
    from mazeslam.data.map_export import export_map, occupancy_from_scans
    from mazeslam.viz.grid_figure import plot_occupancy

    out_dir = Path(out_dir)
    paths = {"figure": draw_slam_figure(out_dir / "slam.png", figure)}
    occupancy = None
    if course_log.is_scan.any():
        occupancy = occupancy_from_scans(course_log, figure.mean_poses, geometry, min_range, max_range)
    paths.update(export_map(out_dir, occupancy, figure.landmarks, figure.landmark_covariances))
    if occupancy is not None:
        paths["occupancy_figure"] = plot_occupancy(out_dir / "occupancy.png", occupancy, figure.title)
    return paths


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
    from mazeslam.viz.slam_view import SlamView, save_animation, view_extent

    extent = view_extent(points, result.mean_poses, truth)
    view = SlamView(result.times, result.mean_poses, extent, title, truth, walls, scan_at, truth_label=truth_label)
    frames = [(index, particles, landmarks) for index, particles, landmarks in result.snapshots]
    return save_animation(view, frames, path, frames_per_second, progress, video)
