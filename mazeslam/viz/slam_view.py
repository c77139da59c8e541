"""The exercise's FastSLAM window, drawn frame by frame: for ``--animate`` (GIF or MP4) and ``--live``.

One figure, world frame in metres: walls and the true path when there are (grey, green), the
estimated path so far (blue), the particles (red), the best particle's landmarks (purple, with
2-sigma ellipses when their covariances are given), the current scan (black) and its corners
(green circles). The artists are made once and only their data change between frames, so a frame
costs a redraw, not a new plot.
"""

from __future__ import annotations

import shutil
from collections.abc import Callable
from pathlib import Path

import matplotlib
import numpy as np
from matplotlib.collections import EllipseCollection, LineCollection
from matplotlib.patches import Ellipse

from mazeslam.core.geometry import transform_points
from mazeslam.core.outputs import written
from mazeslam.viz.backends import close_figure, file_figure
from mazeslam.viz.plots import draw_ellipses

#: ``scan_at(record index) -> (scan points (K, 2), corners (C, 2))`` in the world frame.
ScanSource = Callable[[int], tuple[np.ndarray, np.ndarray]]


class SlamView:
    """A figure of the filter's state that ``show`` updates in place."""

    def __init__(
        self,
        times: np.ndarray,
        mean_poses: np.ndarray,
        extent: np.ndarray,
        title: str = "",
        truth: np.ndarray | None = None,
        walls: np.ndarray | None = None,
        scan_at: ScanSource | None = None,
        figure=None,
        truth_label: str = "true path",
    ):
        self.times, self.mean_poses, self.truth, self.scan_at, self.title = times, mean_poses, truth, scan_at, title
        self.figure = figure if figure is not None else file_figure(figsize=(8.5, 6))
        self.figure.clf()
        ax = self.ax = self.figure.add_subplot(111)
        if walls is not None and len(walls):
            ax.add_collection(
                LineCollection(list(np.asarray(walls).reshape(-1, 2, 2)), colors="0.7", linewidths=1.0, label="walls")
            )
        self.truth_line = (
            ax.plot([], [], color="tab:green", linewidth=1.0, label=truth_label)[0] if truth is not None else None
        )
        self.path_line = ax.plot([], [], color="tab:blue", linewidth=1.2, label="estimated path")[0]
        self.scan_points = ax.plot([], [], ".", color="black", markersize=2, label="current scan")[0]
        self.corners = ax.plot(
            [],
            [],
            "o",
            color="tab:green",
            markersize=7,
            markerfacecolor="none",
            markeredgewidth=1.5,
            label="its corners",
        )[0]
        self.particles = ax.plot([], [], ".", color="red", markersize=3, label="particles")[0]
        self.landmarks = ax.plot([], [], "+", color="tab:purple", markersize=8, label="map (best particle)")[0]
        self.ellipses: EllipseCollection | None = None  # one collection, replaced each frame
        low, high = extent
        ax.set_xlim(low[0], high[0])
        ax.set_ylim(low[1], high[1])
        ax.set_aspect("equal")
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        ax.grid(True, linewidth=0.3, alpha=0.5)
        ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=8)
        self.figure.subplots_adjust(left=0.09, right=0.75, bottom=0.09, top=0.9)

    def show(
        self,
        index: int,
        particles: np.ndarray,
        landmarks: np.ndarray,
        covariances: np.ndarray | None = None,
        path: np.ndarray | None = None,
    ) -> None:
        """Set the figure to record ``index``: particle poses (P, 3), landmarks (L, 2) and their
        covariances (L, 2, 2) (no ellipses when None); ``path`` (N, >=2) the estimated path so far
        (default: ``mean_poses`` up to ``index``)."""
        path = self.mean_poses[: index + 1] if path is None else np.asarray(path).reshape(-1, 3)
        self.path_line.set_data(path[:, 0], path[:, 1])
        if self.truth_line is not None and self.truth is not None:
            self.truth_line.set_data(self.truth[: index + 1, 0], self.truth[: index + 1, 1])
        self.particles.set_data(particles[:, 0], particles[:, 1])
        landmarks = np.asarray(landmarks).reshape(-1, 2)
        self.landmarks.set_data(landmarks[:, 0], landmarks[:, 1])
        if self.ellipses is not None:
            self.ellipses.remove()
        self.ellipses = None if covariances is None else draw_ellipses(self.ax, landmarks, covariances)
        points, corners = self.scan_at(index) if self.scan_at is not None else (np.empty((0, 2)), np.empty((0, 2)))
        self.scan_points.set_data(points[:, 0], points[:, 1])
        self.corners.set_data(corners[:, 0], corners[:, 1])
        self.ax.set_title(f"{self.title}\nt = {self.times[index]:.1f} s, record {index}", fontsize=9)


def ellipse_of(mean, covariance, sigmas: float = 2.0) -> Ellipse:
    """The ``sigmas``-sigma ellipse of a 2-D Gaussian."""
    values, vectors = np.linalg.eigh(covariance)
    angle = np.degrees(np.arctan2(vectors[1, 1], vectors[0, 1]))
    width, height = 2 * sigmas * np.sqrt(np.maximum(values[::-1], 0))
    return Ellipse(mean, width, height, angle=angle, fill=False, color="tab:purple", linewidth=0.8)


def view_extent(*arrays: np.ndarray | None, margin: float = 0.05) -> np.ndarray:
    """(2, 2) lower and upper corners around the (N, >=2) ``arrays``' x, y (None left out), widened by
    ``margin`` of the larger side."""
    points = np.vstack([np.asarray(a)[:, :2] for a in arrays if a is not None and len(a)] or [np.zeros((1, 2))])
    low, high = points.min(axis=0), points.max(axis=0)
    pad = margin * max(float((high - low).max()), 1e-3)
    return np.array([low - pad, high + pad])


def scan_source(course_log, poses: np.ndarray, geometry, extractor) -> ScanSource:
    """``scan_at`` for a log: the scan of a record (or the last scan before it) placed at ``poses``
    (R, 3), and its corners from ``extractor`` (a ``CornerExtractor``)."""
    scans = np.flatnonzero(course_log.is_scan)
    mount = np.array([geometry.mount_x, geometry.mount_y])

    def scan_at(index: int) -> tuple[np.ndarray, np.ndarray]:
        before = scans[scans <= index]
        if not len(before):
            return np.empty((0, 2)), np.empty((0, 2))
        record = int(before[-1])
        features = extractor.extract(course_log.values[record])
        points = transform_points(poses[record], features.points + mount) if len(features.points) else np.empty((0, 2))
        corners = np.array([[o.x, o.y] for o in features.observations]).reshape(-1, 2)
        return points, transform_points(poses[record], corners) if len(corners) else corners

    return scan_at


def ffmpeg_path() -> str | None:
    """An ffmpeg executable: imageio-ffmpeg's (``pip install 'mazeslam[video]'``) or one on PATH."""
    try:
        import imageio_ffmpeg

        return imageio_ffmpeg.get_ffmpeg_exe()
    except (ImportError, RuntimeError):
        return shutil.which("ffmpeg")


def save_animation(
    view: SlamView,
    frames: list,
    path: str | Path,
    frames_per_second: int = 10,
    progress: bool = True,
    video: bool | None = None,
) -> Path:
    """Draw ``frames`` (each the arguments of ``view.show``) into ``path``: an MP4 (suffix .mp4) when
    ffmpeg is available and ``video`` is not False, a GIF otherwise. Returns the path written."""
    from matplotlib.animation import FFMpegWriter, FuncAnimation, PillowWriter
    from tqdm.auto import tqdm

    path = Path(path)
    writer: FFMpegWriter | PillowWriter
    ffmpeg = ffmpeg_path() if video is not False else None
    if ffmpeg is not None:
        matplotlib.rcParams["animation.ffmpeg_path"] = ffmpeg
        path = path.with_suffix(".mp4")
        writer = FFMpegWriter(fps=frames_per_second, codec="libx264", extra_args=["-pix_fmt", "yuv420p"])
    else:
        path = path.with_suffix(".gif")
        writer = PillowWriter(fps=frames_per_second)
    animation = FuncAnimation(view.figure, lambda frame: view.show(*frame), frames=frames, cache_frame_data=False)
    bar = tqdm(total=len(frames), desc=f"drawing {path.name}", unit="frame", disable=not progress)
    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        with written(path) as partial:
            animation.save(partial, writer=writer, dpi=100, progress_callback=lambda done, total: bar.update(1))
    except Exception as error:
        # Interrupted before its first frame, matplotlib's writer still finishes, and Pillow's fails
        # with an IndexError that would hide the interrupt: raise the interrupt itself.
        if isinstance(error.__context__, (KeyboardInterrupt, SystemExit)):
            raise error.__context__ from None
        raise
    finally:
        bar.close()
    close_figure(view.figure)
    return path
