"""``slam --live`` with a non-interactive backend: the view draws off-screen at a bounded rate and
says there is no window."""

import time

import numpy as np
import pytest
from click.testing import CliRunner

from mazeslam.cli.main import main
from mazeslam.core.config import with_settings
from mazeslam.data.loaded_run import load_run
from mazeslam.pipeline import SlamConfig, run_slam


@pytest.fixture(scope="module")
def short_log(tmp_path_factory):
    from mazeslam import simulate

    out = tmp_path_factory.mktemp("live") / "short.log"
    simulate(out, seed=4, duration=15.0, progress=False)
    return out


def test_live_view_counts_frames_off_screen(short_log, monkeypatch):
    monkeypatch.setenv("MPLBACKEND", "Agg")
    from mazeslam.viz.live import LiveView

    run = load_run(short_log)
    view = LiveView(run, SlamConfig().corners, "short.log", max_fps=1000.0)
    assert not view.window and "--animate" in view.message
    began = time.perf_counter()
    result = run_slam(run, progress=False, on_update=view)
    seconds = time.perf_counter() - began
    assert 1 <= view.frames <= len(result.reports)
    # Drawing takes at most about half the time (a frame waits as long as the last one took).
    assert view.drawing_seconds <= 0.5 * seconds + view.drawing_seconds / view.frames + 0.1
    assert len(view.view.particles.get_xdata()) == result.filter.poses.shape[0]
    assert view.view.ax.get_xlabel() == "x [m]"
    view.close()


def test_frame_rate_is_bounded(short_log, monkeypatch):
    monkeypatch.setenv("MPLBACKEND", "Agg")
    from mazeslam.viz.live import LiveView

    run = load_run(short_log)
    view = LiveView(run, SlamConfig().corners, max_fps=2.0)
    began = time.perf_counter()
    run_slam(run, progress=False, on_update=view)
    assert view.frames <= 2.0 * (time.perf_counter() - began) + 1
    view.close()


def test_slam_live_without_a_display_says_so(short_log, tmp_path, monkeypatch):
    monkeypatch.setenv("MPLBACKEND", "Agg")
    result = CliRunner().invoke(main, ["slam", str(short_log), "--live", "--quiet", "--out", str(tmp_path / "out")])
    assert result.exit_code == 0, result.output
    assert "no display" in result.output and "--animate" in result.output
    assert "Live view:" in result.output
    assert (tmp_path / "out" / "slam.png").stat().st_size > 10_000  # the figures still go to files


def test_the_grid_filter_live_draws_its_map_path_and_particles(short_log, tmp_path, monkeypatch):
    """``slam --live`` under ``[map] kind = "grid"``: the grid filter's view, its final frame the
    filter's best map with every particle and the mean path at every scan."""
    monkeypatch.setenv("MPLBACKEND", "Agg")
    from mazeslam.viz.live import GridLiveView

    run = load_run(short_log)
    config = with_settings(SlamConfig(), {"map.kind": "grid", "grid.particles": 3, "grid.linear_update": 0.1})
    view = GridLiveView(run, "short.log", max_fps=1000.0)
    assert not view.window and "--animate" in view.message
    result = run_slam(run, config, progress=False, on_update=view)
    scans = int(run.log.is_scan.sum())
    assert 1 <= view.frames <= scans and len(view.path) == scans
    view.close(len(run.log) - 1, result.filter)
    assert len(view.view.cloud.get_xdata()) == 3 and len(view.view.path_line.get_xdata()) == scans
    assert view.view.image.get_array().size > 1  # the map, not the empty start image
    options = ["slam", str(short_log), "--live", "--quiet", "--map", "grid", "--particles", "3"]
    output = CliRunner().invoke(main, [*options, "--out", str(tmp_path / "out")]).output
    assert "Live view:" in output and "corner FastSLAM only" not in output


def test_corners_live_without_a_display_says_so(short_log, monkeypatch):
    monkeypatch.setenv("MPLBACKEND", "Agg")
    result = CliRunner().invoke(main, ["corners", str(short_log), "--live", "--max-fps", "1000"])
    assert result.exit_code == 0, result.output
    assert "no display" in result.output and "--plot" in result.output and "--animate" in result.output
    assert "Live view:" in result.output and "scans of" in result.output


def test_corners_live_view_draws_the_current_scan_at_a_bounded_rate(short_log, monkeypatch):
    monkeypatch.setenv("MPLBACKEND", "Agg")
    from mazeslam.data.scans import load_scans
    from mazeslam.viz.corner_report import CornerReport
    from mazeslam.viz.live import CornersLiveView

    view = CornersLiveView(load_scans(short_log), max_fps=1000.0)
    assert not view.window
    report = CornerReport.from_log(short_log, progress=False, on_scan=view)
    assert 1 <= view.frames <= len(report.features)
    last = report.features[-1]
    view.close(report)
    # The last frame is the last scan: its points, one line per segment, the robot pointing along +x.
    assert len(view.view.points.get_xdata()) == len(last.points)
    assert len(view.view.lines.get_segments()) == len(last.segments)
    assert view.view.ax.get_xlabel() == "x forward [m]"
    assert "scan" in view.view.ax.get_title()

    slow = CornersLiveView(load_scans(short_log), max_fps=2.0)
    began = time.perf_counter()
    CornerReport.from_log(short_log, progress=False, on_scan=slow)
    assert slow.frames <= 2.0 * (time.perf_counter() - began) + 1
    slow.close()


def test_corners_live_in_a_window_shows_every_scan_at_the_frame_rate(short_log, monkeypatch):
    """With a window, extraction waits for it: every scan is drawn, at most max_fps a second."""
    import matplotlib.pyplot as plt

    from mazeslam.data.scans import load_scans
    from mazeslam.viz import live
    from mazeslam.viz.corner_report import CornerReport

    waits: list[float] = []
    monkeypatch.setenv("MPLBACKEND", "Agg")
    monkeypatch.setattr(live, "window_backend", lambda: (True, "agg"))
    monkeypatch.setattr(plt, "pause", lambda seconds: waits.append(seconds))
    view = live.CornersLiveView(load_scans(short_log), max_fps=50.0)
    assert view.window and view.message is None
    report = CornerReport.from_log(short_log, progress=False, on_scan=view)
    assert view.frames == len(report.features)
    assert waits and max(waits) <= 1 / 50.0 + 1e-9
    view.close(report, keep_open=False)


class FakeWindow:
    """Stands in for a window's time: ``pause`` advances a clock instead of waiting, and after
    ``closed_after`` idle pauses at the end the user "closes" the window."""

    def __init__(self):
        self.now, self.waits = 0.0, []

    def clock(self) -> float:
        return self.now

    def pause(self, seconds: float) -> None:
        self.waits.append(seconds)
        self.now += seconds


def window_view(monkeypatch, short_log, speed: float):
    """A ``LiveView`` that believes it has a window, on the fake clock of a ``FakeWindow``."""
    import matplotlib.pyplot as plt

    from mazeslam.viz import live

    fake = FakeWindow()
    monkeypatch.setenv("MPLBACKEND", "Agg")
    monkeypatch.setattr(live, "window_backend", lambda: (True, "agg"))
    monkeypatch.setattr(plt, "pause", fake.pause)
    view = live.LiveView(load_run(short_log), SlamConfig().corners, "short.log", max_fps=1e9, speed=speed)
    view.pacing.clock = fake.clock
    return view, fake


@pytest.mark.parametrize("speed", [1.0, 4.0])
def test_a_window_plays_the_log_at_its_own_pace_times_the_speed(short_log, monkeypatch, speed):
    """Issue 35: the filter runs far faster than the log's clock; in a window each update waits until
    its record is due, so the last update is shown (log duration / speed) after the first."""
    view, fake = window_view(monkeypatch, short_log, speed)
    run = load_run(short_log)
    run_slam(run, progress=False, on_update=view)
    updates = np.flatnonzero(run.log.is_scan)  # corner FastSLAM updates at each scan
    expected = (run.log.times[updates[-1]] - run.log.times[updates[0]]) / speed
    assert fake.now == pytest.approx(expected, abs=0.01)  # the frames' own pauses (1 ms each) add a little
    view.close(keep_open=False)


def test_the_pause_key_holds_the_log_and_a_finished_window_stays_open_until_closed(short_log, monkeypatch):
    import matplotlib.pyplot as plt

    from mazeslam.viz import live

    view, fake = window_view(monkeypatch, short_log, 1.0)
    key = type("Key", (), {"key": live.PAUSE_KEY})()
    view.on_key(key)
    assert view.paused
    pauses_while_paused = []

    def pause(seconds):  # the user resumes after five idle pauses
        fake.pause(seconds)
        if view.paused:
            pauses_while_paused.append(seconds)
            if len(pauses_while_paused) == 5:
                view.on_key(key)

    monkeypatch.setattr(plt, "pause", pause)
    run = load_run(short_log)
    result = run_slam(run, progress=False, on_update=view)
    assert pauses_while_paused == [live.IDLE_SECONDS] * 5 and not view.paused
    # The time held paused does not count against the pace: the log still plays from where it was.
    scans = run.log.times[run.log.is_scan]
    assert fake.now == pytest.approx(scans[-1] - scans[0] + 5 * live.IDLE_SECONDS, abs=0.01)

    idle = []

    def closed_by_user(seconds):  # the finished window waits until the user closes it (the third idle pause)
        idle.append(seconds)
        if len(idle) == 3:
            plt.close(view.view.figure)

    monkeypatch.setattr(plt, "pause", closed_by_user)
    view.close(len(run.log) - 1, result.filter)
    assert len(idle) == 3 and not plt.fignum_exists(view.view.figure.number)
    assert view.view.figure.get_suptitle() == live.FINISHED


def test_pacing_says_how_early_or_late_each_record_is():
    from mazeslam.viz.live import Pacing

    clock = FakeWindow()
    pacing = Pacing(np.array([9.0, 10.0, 11.0, 13.0, 14.0]), speed=2.0, clock=clock.clock)
    assert pacing.lateness(1) == 0.0  # the first record shown sets the clock
    assert pacing.lateness(2) == -0.5  # one log second at twice its pace: half a second early
    clock.now = 0.5
    assert pacing.lateness(3) == -1.0
    clock.now = 5.0  # the filter fell behind: due at 2 s, 3 s late
    assert pacing.lateness(4) == 3.0
    with pytest.raises(ValueError, match="speed must be positive"):
        Pacing(np.zeros(2), speed=0.0)


class SteppedClock:
    """A ``FilterView`` clock: each reading first advances it by ``cost`` (the work since the last
    reading), ``wait`` advances it at once."""

    def __init__(self, cost: float):
        self.time, self.cost, self.waits = 0.0, cost, []

    def now(self) -> float:
        self.time += self.cost
        return self.time

    def wait(self, seconds: float) -> None:
        self.waits.append(seconds)
        self.time += seconds


@pytest.mark.parametrize("cost", [0.0, 30.0])
def test_an_off_screen_view_given_a_clock_plays_the_log_at_its_pace_on_it(short_log, monkeypatch, cost):
    """A fast filter waits for each scan (early by the log's gap between updates), a slow one never
    waits and is late (the first update sets the clock)."""
    from mazeslam.viz import live

    monkeypatch.setenv("MPLBACKEND", "Agg")
    run = load_run(short_log)
    clock = SteppedClock(cost)
    view = live.LiveView(run, SlamConfig().corners, "short.log", max_fps=1e9, clock=clock)
    assert not view.window
    run_slam(run, progress=False, on_update=view)
    view.close(keep_open=False)
    gaps = np.diff(run.log.times[run.log.is_scan])  # corner FastSLAM updates at each scan
    assert len(view.lateness) == len(gaps) + 1 and view.lateness[0] == 0.0
    if cost == 0.0:
        np.testing.assert_allclose(view.lateness[1:], -gaps, atol=1e-9)
        np.testing.assert_allclose(clock.waits, gaps[gaps > 0], atol=1e-9)
    else:
        assert min(view.lateness[1:]) > 0 and not clock.waits


def test_an_off_screen_view_given_a_clock_draws_at_most_max_fps_frames_a_second_of_it(short_log, monkeypatch):
    """On a clock that only the log's pace moves, a frame is drawn at the first update and then at
    each update at least 1 / max_fps seconds of that clock after the last frame."""
    from mazeslam.viz import live

    monkeypatch.setenv("MPLBACKEND", "Agg")
    run = load_run(short_log)
    view = live.LiveView(run, SlamConfig().corners, "short.log", max_fps=0.5, clock=SteppedClock(0.0))
    run_slam(run, progress=False, on_update=view)
    shown = run.log.times[run.log.is_scan] - run.log.times[run.log.is_scan][0]  # when each update is shown
    expected, last = 0, -np.inf
    for time_shown in shown:
        if time_shown - last >= 2.0:
            expected, last = expected + 1, time_shown
    assert 1 < expected < len(shown)  # the rate bounds it: not every update, not only the first
    assert view.frames == expected
    view.close(keep_open=False)
