"""Issue 36, items 4 and 5: a run too short for one scan is refused before any file is written,
and the batched ray cast returns (never loops) on a NaN pose."""

import subprocess
import sys
import threading

import numpy as np
import pytest

from mazeslam import simulate
from mazeslam.data import log
from mazeslam.sim.batched import MazeGrids
from mazeslam.sim.maze import generate_maze
from mazeslam.sim.policies import ScriptedPolicy
from mazeslam.sim.simulator import LoggerParams, first_scan_time, too_short_problem


@pytest.mark.parametrize("duration", [0.05, 0.1, 0.19, 0.5, 0.74])
def test_simulate_refuses_a_duration_too_short_for_one_scan_and_writes_nothing(tmp_path, duration):
    # The reproducer: simulate(..., duration=0.05) returned 0 records and left a 0-byte log.
    with pytest.raises(ValueError, match=rf"^duration: {duration:g} s is too short for one scan: .*at least 0.76 s$"):
        simulate(tmp_path / "short.log", duration=duration, progress=False)
    assert list(tmp_path.iterdir()) == []


def test_the_stated_minimum_gives_a_scan(tmp_path):
    minimum = first_scan_time(LoggerParams())
    assert minimum == pytest.approx(0.76)  # the physics step (0.02 s) at or after scan_period 0.75 s
    result = simulate(tmp_path / "one.log", duration=minimum, progress=False)
    assert log.read(result.log_path).is_scan.sum() == 1


@pytest.mark.parametrize(
    "logger",
    [LoggerParams(), LoggerParams(scan_period=0.1, physics_rate=30), LoggerParams(scan_phase=-0.5, physics_rate=7)],
)
def test_too_short_problem_agrees_with_the_run(tmp_path, logger):
    from dataclasses import replace

    from mazeslam.sim.simulator import SimulationConfig

    config = replace(SimulationConfig(), logger=replace(logger, odometry_rate=min(5.0, logger.physics_rate)))
    first, dt = first_scan_time(logger), 1 / logger.physics_rate
    for duration in (first - dt, first - dt / 2, first):
        path = tmp_path / "run.log"
        if too_short_problem(duration, logger):
            with pytest.raises(ValueError, match="too short for one scan"):
                simulate(path, config=config, duration=duration, progress=False)
            assert not path.exists()
        else:
            simulate(path, config=config, duration=duration, progress=False)
            assert log.read(path).is_scan.sum() >= 1
            path.unlink()


def test_a_policy_that_ends_before_the_first_scan_leaves_no_file(tmp_path):
    with pytest.raises(ValueError, match=r"the policy finished at 0.12 s, before the first scan at 0.76 s"):
        simulate(tmp_path / "brief.log", policy=ScriptedPolicy([(0.1, 0.05, 0.0)]), progress=False)
    assert list(tmp_path.iterdir()) == []


def test_cli_simulate_refuses_a_too_short_duration_in_one_line_and_writes_nothing(tmp_path):
    # The reproducer: `mazeslam simulate --duration 0.1`: an IndexError traceback and a 0-byte log.
    out = tmp_path / "runs" / "short.log"
    process = subprocess.run(
        [sys.executable, "-m", "mazeslam.cli", "simulate", "--duration", "0.1", "--out", str(out), "--quiet"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert process.returncode == 2
    assert "Traceback" not in process.stderr
    errors = [line for line in process.stderr.splitlines() if line.startswith("Error")]
    assert errors == [
        "Error: Invalid value for '--duration': 0.1 s is too short for one scan: the first is taken at 0.76 s "
        "(logger scan_period 0.75 s); at least 0.76 s"
    ]
    assert not out.parent.exists() or list(out.parent.iterdir()) == []


@pytest.mark.filterwarnings("ignore:invalid value encountered:RuntimeWarning")
@pytest.mark.filterwarnings("ignore:divide by zero encountered:RuntimeWarning")
def test_batched_ray_cast_returns_on_a_nan_pose():
    # A NaN pose (from a NaN action) made _BandCrossings.hits loop forever.
    maze = generate_maze(3, 3, 0)
    grids = MazeGrids.like(maze, 2)
    grids.set(0, maze)
    grids.set(1, maze)
    bearings = np.linspace(-np.pi, np.pi, 90, endpoint=False)
    result = {}
    cast = threading.Thread(
        target=lambda: result.update(
            ranges=grids.cast_edges(
                np.arange(2), np.array([np.nan, 0.225]), np.array([0.075, 0.225]), np.array([0.0, 0.0]), bearings, 0.8
            )[0]
        ),
        daemon=True,
    )
    cast.start()
    cast.join(10)
    assert not cast.is_alive(), "the cast hangs on a NaN pose"
    ranges = result["ranges"]
    assert np.isinf(ranges[0]).all()  # no wall for a ray from nowhere
    assert np.isfinite(ranges[1]).all() and (ranges[1] > 0).all()  # the other sensor is unaffected
