"""``mazeslam slam --live`` and ``mazeslam corners --live``: windows updated as the log is processed.

The window is ``SlamView`` (map of the best particle with 2-sigma ellipses, particles, the current
scan and its corners, the estimated path, truth and walls when the log has them). It is redrawn
after an observation update at most ``max_fps`` times a second, and never sooner than the last
redraw took, so drawing takes at most about half of the wall-clock time: the filter runs at least
half as fast as without the window.

``GridLiveView`` is the same for the grid filter (``[map] kind = "grid"``): the best particle's map,
the mean path, the particles and the truth when the log has one (``GridView``), redrawn after a
scan as often as ``LiveView``.

``CornersLiveView`` is the same for ``mazeslam corners``: the current scan in the robot frame, its
extracted lines and corners, and the robot (a triangle along its heading, +x), redrawn as scans are
extracted, at most ``max_fps`` times a second. In a window every scan is shown (extraction waits for
the window: it is far faster than anyone can watch); off-screen, scans in between are skipped and a
frame is never drawn sooner than the last one took.

A window needs a display and an interactive matplotlib backend (Qt, Tk, GTK, macOS). Without one
(``MPLBACKEND=Agg``, a server without ``DISPLAY``) the view draws into an off-screen figure and
``LiveView.message`` says so and suggests ``--animate``, which writes the same frames to a video.
"""

from __future__ import annotations

import os
import sys
import time
from typing import Any

import matplotlib
import numpy as np

from mazeslam.core.geometry import transform_points
from mazeslam.viz.slam_view import SlamView, view_extent

#: Backends tried for a window, in order, when ``MPLBACKEND`` does not name one.
WINDOW_BACKENDS = ("QtAgg", "TkAgg", "GTK4Agg", "GTK3Agg", "macosx")
NON_INTERACTIVE = {"agg", "pdf", "ps", "svg", "pgf", "cairo", "template"}


def choose_backend() -> tuple[bool, str]:
    """Switch matplotlib to a window backend if there is a display; returns (whether a window
    can open, the backend in use). ``MPLBACKEND`` is obeyed when set."""
    import matplotlib.pyplot as plt

    wanted = os.environ.get("MPLBACKEND")
    has_display = sys.platform in ("darwin", "win32") or bool(
        os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")
    )
    candidates = [wanted] if wanted else (WINDOW_BACKENDS if has_display else ())
    for backend in candidates:
        try:
            plt.switch_backend(backend)
        except (ImportError, RuntimeError, ValueError):
            continue
        return matplotlib.get_backend().lower() not in NON_INTERACTIVE, matplotlib.get_backend()
    plt.switch_backend("Agg")
    return False, "agg"


class FilterView:
    """What both filters' live views share: a window (or an off-screen figure, ``message`` saying
    so), the mean pose after each update (``path``), redrawing at most ``max_fps`` times a second
    and never sooner than the last redraw took, and the final frame on ``close``. A subclass makes
    ``self.view`` (with a ``figure``) and ``draw(index, slam)``.

    Attributes:
        frames: how many frames were drawn.
        window: whether they went to a window on screen.
        message: what to tell the user when there is no window (None when there is).
        path: the filter's mean pose (3,) after each update.
    """

    view: Any

    def __init__(self, max_fps: float):
        import matplotlib.pyplot as plt

        self.window, backend = choose_backend()
        self.message = (
            None
            if self.window
            else no_window_message(backend, "Use --animate to write the run as slam.mp4/slam.gif instead.")
        )
        if self.window:
            plt.ion()
        self.max_fps = max_fps
        self.path: list[np.ndarray] = []
        self.frames, self.drawing_seconds = 0, 0.0
        self._last, self._last_cost = -np.inf, 0.0

    def mean_pose(self, slam) -> np.ndarray:
        """The filter's weighted-mean pose (3,)."""
        raise NotImplementedError

    def __call__(self, index: int, slam) -> None:
        self.path.append(self.mean_pose(slam))
        now = time.perf_counter()
        if now - self._last < max(1.0 / self.max_fps, self._last_cost):
            return
        self.draw(index, slam)
        self._last = time.perf_counter()
        self._last_cost = self._last - now
        self.drawing_seconds += self._last_cost

    def draw(self, index: int, slam) -> None:
        """Draw one frame of the filter's state after record ``index``."""
        raise NotImplementedError

    def show_frame(self) -> None:
        """Put the frame just drawn on screen (or render it off-screen) and count it."""
        import matplotlib.pyplot as plt

        if self.window:
            plt.pause(0.001)
        else:
            self.view.figure.canvas.draw()
        self.frames += 1

    def close(self, index: int | None = None, slam=None) -> None:
        """Draw the final state (when given), then close the window and return to drawing files."""
        import matplotlib.pyplot as plt

        if slam is not None and index is not None:
            self.draw(index, slam)
            if self.window:
                plt.pause(1.0)
        plt.close(self.view.figure)
        plt.switch_backend("Agg")


class LiveView(FilterView):
    """``on_update`` for ``run_slam`` with corner FastSLAM: its particles, the best particle's map,
    the current scan and its corners, in a window (or off-screen; ``FilterView``)."""

    def __init__(self, run, corner_params, title: str = "", max_fps: float = 5.0):
        from mazeslam.features.corners import CornerExtractor

        super().__init__(max_fps)
        self.run = run
        self.extractor = CornerExtractor(run.geometry, run.log.width, corner_params) if run.log.n_beams else None
        self.mount = np.array([run.geometry.mount_x, run.geometry.mount_y])
        extent = view_extent(
            run.truth,
            np.asarray(run.start_pose)[None],
            run.walls.reshape(-1, 2) if run.walls is not None and len(run.walls) else None,
            margin=0.3,
        )
        self.view = SlamView(run.log.times, np.zeros((0, 3)), extent, title, run.truth, run.walls)
        self.view.scan_at = self._scan

    def _scan(self, index: int) -> tuple[np.ndarray, np.ndarray]:
        """The record's scan and corners placed at the current mean pose (none for other records)."""
        if self.extractor is None or not self.run.log.is_scan[index]:
            return np.empty((0, 2)), np.empty((0, 2))
        features = self.extractor.extract(self.run.log.values[index])
        pose = self.path[-1] if self.path else np.zeros(3)
        points = transform_points(pose, features.points + self.mount) if len(features.points) else np.empty((0, 2))
        corners = np.array([[o.x, o.y] for o in features.observations]).reshape(-1, 2)
        return points, transform_points(pose, corners) if len(corners) else corners

    def mean_pose(self, slam) -> np.ndarray:
        return slam.mean_pose()

    def draw(self, index: int, slam) -> None:
        landmarks, covariances = slam.landmarks()
        self.view.show(index, slam.poses, landmarks, covariances, path=np.array(self.path))
        self.show_frame()


class GridLiveView(FilterView):
    """``on_update`` for ``run_slam`` with the grid filter: the best particle's map, the mean path,
    the particles and the truth when the log has one (``GridView``), in a window (or off-screen;
    ``FilterView``)."""

    def __init__(self, run, title: str = "", max_fps: float = 5.0):
        from mazeslam.viz.grid_animation import GridView

        super().__init__(max_fps)
        self.run, self.scans = run, int(run.log.is_scan.sum())
        start = np.asarray(run.start_pose, dtype=float)[:2]
        self.low, self.high = start.copy(), start.copy()
        if run.truth is not None:
            self.low, self.high = run.truth[:, :2].min(axis=0), run.truth[:, :2].max(axis=0)
        self.view = GridView(self.low, self.high, title, run.truth_path_label)

    def mean_pose(self, slam) -> np.ndarray:
        return slam.cloud(np.zeros(3))[1]

    def draw(self, index: int, slam) -> None:
        from mazeslam.gridslam.snapshots import snapshot
        from mazeslam.viz.grid_animation import occupancy_corners

        frame = snapshot(len(self.path) - 1, slam.maps[slam.best_particle()], slam.poses)
        path = np.array(self.path)
        area = np.vstack([occupancy_corners(frame.occupancy), path[:, :2], self.low, self.high])
        self.view.frame_area(area.min(axis=0), area.max(axis=0))
        truth = self.run.truth[: index + 1] if self.run.truth is not None else None
        self.view.show(frame, path, truth, self.scans)
        self.show_frame()


def no_window_message(backend: str, instead: str) -> str:
    """What to tell the user when ``--live`` has no window, and which non-live output to use."""
    return f"--live: no display for a window (matplotlib backend {backend}); drawing off-screen only. {instead}"


class CornersLiveView:
    """``on_scan`` for ``CornerReport.from_log``: the current scan, its lines and corners in a window
    (or off-screen), redrawn at most ``max_fps`` times a second.

    Attributes:
        frames: how many frames were drawn; window: whether they went to a window on screen;
        message: what to tell the user when there is no window (None when there is).
    """

    def __init__(self, scans, max_range: float = np.inf, max_fps: float = 5.0):
        import matplotlib.pyplot as plt

        from mazeslam.viz.corner_plots import ScanView

        self.window, backend = choose_backend()
        self.message = (
            None
            if self.window
            else no_window_message(
                backend, "Use --plot scan.png (one scan) or --animate scans.gif (every scan) to write them to files."
            )
        )
        if self.window:
            plt.ion()
        self.max_fps = max_fps
        ranges = np.asarray(scans.ranges, dtype=float)
        seen = ranges[(ranges > 0) & np.isfinite(ranges) & (ranges <= max_range)]
        mount = np.array([scans.geometry.mount_x, scans.geometry.mount_y])
        reach = 1.05 * (float(seen.max()) if len(seen) else 1.0) + float(np.hypot(*mount))
        self.figure, ax = plt.subplots(figsize=(7, 7.5), layout="constrained")
        self.view = ScanView(ax, mount, reach=reach, truth=scans.true_corners is not None)
        handles, labels = ax.get_legend_handles_labels()
        self.figure.legend(handles, labels, loc="outside lower center", ncol=4, fontsize=7)
        self.frames, self.drawing_seconds = 0, 0.0
        self._last, self._last_cost = -np.inf, 0.0

    def __call__(self, report, index: int) -> None:
        now = time.perf_counter()
        if self.window:
            # On screen every scan is shown, at most max_fps a second: extraction (thousands of scans
            # a second) waits for the window, or a log would flash past in a fraction of a second.
            import matplotlib.pyplot as plt

            wait = self._last + 1.0 / self.max_fps - now
            if wait > 0:
                plt.pause(wait)
                now = time.perf_counter()
        elif now - self._last < max(1.0 / self.max_fps, self._last_cost):
            return
        self.draw(report, index)
        self._last = time.perf_counter()
        self._last_cost = self._last - now
        self.drawing_seconds += self._last_cost

    def draw(self, report, index: int) -> None:
        """Draw scan ``index`` of ``report`` (a ``CornerReport`` being filled)."""
        import matplotlib.pyplot as plt

        self.view.show(report.features[index], report.title(index), report.true_corners(index))
        if self.frames == 1:
            self.figure.set_layout_engine("none")  # laid out by the first frame: the others differ in data only
        if self.window:
            plt.pause(0.001)
        else:
            self.figure.canvas.draw()
        self.frames += 1

    def close(self, report=None) -> None:
        """Draw the last scan (when given), then close the window and return to drawing files."""
        import matplotlib.pyplot as plt

        if report is not None and report.features:
            self.draw(report, len(report.features) - 1)
            if self.window:
                plt.pause(1.0)
        plt.close(self.figure)
        plt.switch_backend("Agg")
