"""``mazeslam slam --live`` and ``mazeslam corners --live``: windows updated as the log is processed.

The window is ``SlamView`` (map of the best particle with 2-sigma ellipses, particles, the current
scan and its corners, the estimated path, truth and walls when the log has them). In a window the
log plays at its own pace (``Pacing``; ``speed`` times it with ``mazeslam slam --speed``), the space
bar pauses and resumes, and the last frame stays open until the window is closed. It is redrawn
after an observation update at most ``max_fps`` times a second, and never sooner than the last
redraw took.

``GridLiveView`` is the same for the grid filter (``[map] kind = "grid"``): the best particle's map,
the mean path, the particles and the truth when the log has one (``GridView``), redrawn after a
scan as often as ``LiveView``.

``CornersLiveView`` is the same for ``mazeslam corners``: the current scan in the robot frame, its
extracted lines and corners, and the robot (a triangle along its heading, +x), redrawn as scans are
extracted, at most ``max_fps`` times a second. In a window every scan is shown (extraction waits for
the window: it is far faster than anyone can watch) and the last scan stays open until the window is
closed; off-screen, scans in between are skipped and a frame is never drawn sooner than the last one took.

A window needs a display and an interactive matplotlib backend (Qt, Tk, GTK, macOS). Without one
(``MPLBACKEND=Agg``, a server without ``DISPLAY``) the view draws into an off-screen figure and
``LiveView.message`` says so and suggests ``--animate``, which writes the same frames to a video.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np

from mazeslam.core.geometry import transform_points
from mazeslam.viz.backends import window_backend
from mazeslam.viz.slam_view import SlamView, view_extent

#: The key that pauses and resumes a live window.
PAUSE_KEY = " "
#: How often a paused or finished window is looked at, s.
IDLE_SECONDS = 0.1
#: What a playing window's title adds.
PLAYING = "space: pause / resume"
#: What a finished window's title adds.
FINISHED = "finished: close the window (or press q) to go on"


class Pacing:
    """Plays a log at ``speed`` times its own pace: how late (or, negative, early) a record is on the
    ``clock`` against the log's time since the first record shown divided by ``speed``; the view
    waits out an early record and never a late one.

    Args:
        times: (R,) the log's record times, s.
        speed: how many log seconds a wall-clock second shows (1: the log's own pace).
        clock: the wall clock, s (``time.perf_counter``).
    """

    def __init__(self, times: np.ndarray, speed: float = 1.0, clock: Callable[[], float] = time.perf_counter):
        if not speed > 0:
            raise ValueError(f"the live view's speed must be positive, got {speed}")
        self.times, self.speed, self.clock = np.asarray(times, dtype=float), float(speed), clock
        self._started: float | None = None
        self._first = 0.0

    def lateness(self, index: int) -> float:
        """How late record ``index`` is now, s (negative: early by that much; the first record shown
        is on time)."""
        now = self.clock()
        if self._started is None:
            self._started, self._first = now, float(self.times[index])
        return now - (self._started + (self.times[index] - self._first) / self.speed)

    def hold(self, seconds: float) -> None:
        """Time spent paused does not count against the log's pace."""
        if self._started is not None:
            self._started += seconds


class WindowClock:
    """The live window's clock: the wall clock, waited on with the window kept responsive."""

    def now(self) -> float:
        """Seconds on the wall clock (``time.perf_counter``)."""
        return time.perf_counter()

    def wait(self, seconds: float) -> None:
        """Let ``seconds`` pass, the window drawing and answering keys meanwhile."""
        import matplotlib.pyplot as plt

        plt.pause(seconds)


class FilterView:
    """What both filters' live views share: a window (or an off-screen figure, ``message`` saying
    so), the mean pose after each update (``path``), and the final frame on ``close``. A subclass
    makes ``self.view`` (with a ``figure``) and ``draw(index, slam)``.

    In a window the log plays at ``speed`` times its own pace (``Pacing``), the space bar pauses and
    resumes it, closing the window lets the filter finish without it, and ``close`` keeps the last
    frame open until the window is closed. Frames are drawn at most ``max_fps`` times a second and
    never sooner than the last one took (off-screen too, where nothing waits for the log's pace).

    ``clock`` (an object with ``now()`` and ``wait(seconds)``, default ``WindowClock``) is the time
    the view paces the log and throttles frames by. Given one, the view plays the log at its pace
    off-screen too, waiting on that clock: a replay on a simulated clock
    (``benchmarks/bench_grid.py`` measures whether the grid filter keeps up this way).

    Attributes:
        frames: how many frames were drawn.
        window: whether they went to a window on screen.
        message: what to tell the user when there is no window (None when there is).
        path: the filter's mean pose (3,) after each update.
        lateness: how late each paced update ended after its record was due, s (negative: early;
            empty where the log is not paced).
        paused: the window's pause key was pressed (and not again).
    """

    view: Any

    def __init__(self, times: np.ndarray, max_fps: float, speed: float = 1.0, clock=None):
        import matplotlib.pyplot as plt

        self.window, backend = window_backend()
        self.message = (
            None
            if self.window
            else no_window_message(backend, "Use --animate to write the run as slam.mp4/slam.gif instead.")
        )
        if self.window:
            plt.ion()
        self.paced = self.window or clock is not None
        self.clock = WindowClock() if clock is None else clock
        self.pacing = Pacing(times, speed, self.clock.now)
        self.max_fps = max_fps
        self.path: list[np.ndarray] = []
        self.lateness: list[float] = []
        self.frames, self.drawing_seconds = 0, 0.0
        self.paused = False
        self._last, self._last_cost = -np.inf, 0.0

    def watch_keys(self) -> None:
        """Listen to the window's pause key (a subclass calls it once ``self.view`` exists)."""
        if self.window:
            self.view.figure.canvas.mpl_connect("key_press_event", self.on_key)
            self.view.figure.suptitle(PLAYING, fontsize=9, color="0.4")

    def on_key(self, event) -> None:
        """The pause key toggles ``paused``."""
        if event.key == PAUSE_KEY:
            self.paused = not self.paused

    @property
    def open(self) -> bool:
        """The window is still on screen (False off-screen)."""
        import matplotlib.pyplot as plt

        return self.window and plt.fignum_exists(self.view.figure.number)

    def mean_pose(self, slam) -> np.ndarray:
        """The filter's weighted-mean pose (3,)."""
        raise NotImplementedError

    def __call__(self, index: int, slam) -> None:
        self.path.append(self.mean_pose(slam))
        if self.window and not self.open:
            return  # closed by the user: the filter goes on without it
        if self.paced:
            self._keep_pace(index)
        now = self.clock.now()
        if now - self._last < max(1.0 / self.max_fps, self._last_cost):
            return
        self.draw(index, slam)
        self._last = self.clock.now()
        self._last_cost = self._last - now
        self.drawing_seconds += self._last_cost

    def _keep_pace(self, index: int) -> None:
        """Wait (the window responsive meanwhile) while paused and until record ``index`` is due."""
        while self.paused and self.open:
            self.clock.wait(IDLE_SECONDS)
            self.pacing.hold(IDLE_SECONDS)
        self.lateness.append(self.pacing.lateness(index))
        if self.lateness[-1] < 0 and (self.open or not self.window):
            self.clock.wait(-self.lateness[-1])

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

    def close(self, index: int | None = None, slam=None, keep_open: bool = True) -> None:
        """Draw the final state (when given); a window then stays open until the user closes it
        (``keep_open``), and is closed."""
        import matplotlib.pyplot as plt

        if slam is not None and index is not None and (self.open or not self.window):
            self.draw(index, slam)
        if keep_open:
            wait_until_closed(self.view.figure, self.window)
        plt.close(self.view.figure)


def wait_until_closed(figure, window: bool) -> None:
    """Keep ``figure``'s window on screen, its title saying it is finished, until the user closes it
    (nothing off-screen, or when it is closed already)."""
    import matplotlib.pyplot as plt

    if not window or not plt.fignum_exists(figure.number):
        return
    figure.suptitle(FINISHED, fontsize=9, color="tab:red")
    while plt.fignum_exists(figure.number):
        plt.pause(IDLE_SECONDS)


class LiveView(FilterView):
    """``on_update`` for ``run_slam`` with corner FastSLAM: its particles, the best particle's map,
    the current scan and its corners, in a window (or off-screen; ``FilterView``)."""

    def __init__(self, run, corner_params, title: str = "", max_fps: float = 5.0, speed: float = 1.0, clock=None):
        import matplotlib.pyplot as plt

        from mazeslam.features.corners import CornerExtractor

        super().__init__(run.log.times, max_fps, speed, clock)
        self.run = run
        self.extractor = CornerExtractor(run.geometry, run.log.width, corner_params) if run.log.n_beams else None
        self.mount = np.array([run.geometry.mount_x, run.geometry.mount_y])
        extent = view_extent(
            run.truth,
            np.asarray(run.start_pose)[None],
            run.walls.reshape(-1, 2) if run.walls is not None and len(run.walls) else None,
            margin=0.3,
        )
        figure = plt.figure(figsize=(8.5, 6))
        self.view = SlamView(run.log.times, np.zeros((0, 3)), extent, title, run.truth, run.walls, figure=figure)
        self.watch_keys()
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

    def __init__(self, run, title: str = "", max_fps: float = 5.0, speed: float = 1.0, clock=None):
        import matplotlib.pyplot as plt

        from mazeslam.viz.grid_animation import GridView

        super().__init__(run.log.times, max_fps, speed, clock)
        self.run, self.scans = run, int(run.log.is_scan.sum())
        start = np.asarray(run.start_pose, dtype=float)[:2]
        self.low, self.high = start.copy(), start.copy()
        if run.truth is not None:
            self.low, self.high = run.truth[:, :2].min(axis=0), run.truth[:, :2].max(axis=0)
        figure = plt.figure(figsize=(8.5, 6.5))
        self.view = GridView(self.low, self.high, title, run.truth_path_label, figure=figure)
        self.watch_keys()

    def mean_pose(self, slam) -> np.ndarray:
        return slam.cloud(np.zeros(3))[1]

    def draw(self, index: int, slam) -> None:
        from mazeslam.gridslam.snapshots import snapshot
        from mazeslam.viz.grid_animation import occupancy_corners

        frame = snapshot(len(self.path) - 1, slam.map_of(slam.best_particle()), slam.poses)
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

        self.window, backend = window_backend()
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

    def close(self, report=None, keep_open: bool = True) -> None:
        """Draw the last scan (when given); a window then stays open until the user closes it
        (``keep_open``), and is closed."""
        import matplotlib.pyplot as plt

        if report is not None and report.features:
            self.draw(report, len(report.features) - 1)
        if keep_open:
            wait_until_closed(self.figure, self.window)
        plt.close(self.figure)
