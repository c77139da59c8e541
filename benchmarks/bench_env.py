"""Benchmark: mazeslam/Maze-v0 steps per second (180 beams, 16 x 16 maze, one process), side by
side with ir-sim stepping a comparable robot (differential drive, 37 mm disc) with a comparable
lidar (180 beams over 360 degrees, 0.8 m) among the same maze walls, in the same run.
Targets: at least 2000 steps/s and 3x ir-sim's rate. ir-sim is pinned (``IRSIM_VERSION``): the
benchmark installs that version with pip when another or none is there (``--no-install`` or
``MAZESLAM_BENCH_NO_INSTALL=1`` to never install); when it cannot, it reports ir-sim as skipped,
with the reason. Rates are per wall-clock second; with ``--cpu-time`` (or
``MAZESLAM_BENCH_CLOCK=cpu``) per second of this process's CPU time, every rate of the run alike:
on a machine shared with other work, the wall clock also counts the time others hold the cores.
Run: ``python benchmarks/bench_env.py``.
"""

from __future__ import annotations

import importlib
import importlib.metadata
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import gymnasium as gym
import numpy as np

import mazeslam  # noqa: F401  (registers the environments)
from mazeslam.sim.maze import generate_maze

ROWS = COLS = 16
STEPS = 1000
TARGET_RATE = 2000.0
TARGET_RATIO = 3.0


def clock() -> float:
    """Seconds for the benchmark's rates: wall clock, or this process's CPU time (``--cpu-time``)."""
    return time.process_time() if uses_cpu_time() else time.perf_counter()


def uses_cpu_time() -> bool:
    return "--cpu-time" in sys.argv or os.environ.get("MAZESLAM_BENCH_CLOCK") == "cpu"


def clock_name() -> str:
    return "CPU time of this process" if uses_cpu_time() else "wall clock"


#: The ir-sim release compared against (the one the issues' figures were measured with).
IRSIM_VERSION = "2.12.0"


def installed_irsim() -> str | None:
    """The installed ir-sim's version, or None."""
    try:
        return importlib.metadata.version("ir-sim")
    except importlib.metadata.PackageNotFoundError:
        return None


def ensure_irsim() -> str | None:
    """Make ir-sim ``IRSIM_VERSION`` importable, installing it with pip unless told not to; return
    None when it is, else why it is not (for the report: never skipped silently)."""
    if installed_irsim() == IRSIM_VERSION:
        return None
    found = installed_irsim() or "none"
    if "--no-install" in sys.argv or os.environ.get("MAZESLAM_BENCH_NO_INSTALL"):
        return f"ir-sim {IRSIM_VERSION} is not installed (found: {found}) and installing is turned off"
    print(f"installing ir-sim {IRSIM_VERSION} (found: {found}) for the comparison ...", file=sys.stderr, flush=True)
    command = [sys.executable, "-m", "pip", "install", "--quiet", f"ir-sim=={IRSIM_VERSION}"]
    result = subprocess.run(command, capture_output=True, text=True)
    importlib.invalidate_caches()
    if result.returncode != 0 or installed_irsim() != IRSIM_VERSION:
        last = (result.stderr.strip().splitlines() or ["no message"])[-1]
        return f"pip could not install ir-sim {IRSIM_VERSION}: {last}"
    return None


def irsim_comparison(maze, steps: int = 300) -> tuple[float | None, str | None]:
    """ir-sim's steps/s in ``maze`` (``irsim_rate``), or None and why it was skipped."""
    reason = ensure_irsim()
    if reason is not None:
        return None, reason
    try:
        return irsim_rate(maze, steps), None
    except Exception as error:  # a failing comparison is reported, not fatal
        return None, f"ir-sim {IRSIM_VERSION} failed: {type(error).__name__}: {error}"


def mazeslam_rate(maze) -> float:
    env = gym.make("mazeslam/Maze-v0", maze=maze, max_steps=10 * STEPS)
    env.reset(seed=0)
    env.action_space.seed(0)
    actions = [env.action_space.sample() for _ in range(STEPS)]
    began = clock()
    for action in actions:
        env.step(action)
    return STEPS / (clock() - began)


def irsim_rate(maze, steps: int = 300) -> float:
    """ir-sim's steps per second, its robot and 180-beam lidar among ``maze``'s wall boxes."""
    os.environ.setdefault("MPLBACKEND", "Agg")
    import irsim

    from mazeslam.sim.walls import wall_geometry

    obstacles = "\n".join(
        f"  - shape: {{name: 'polygon', vertices: [[{a}, {b}], [{c}, {b}], [{c}, {d}], [{a}, {d}]]}}\n"
        f"    state: [0, 0, 0]"
        for a, b, c, d in wall_geometry(maze).boxes
    )
    start = maze.cell_center(0, 0)
    world = f"""world:
  height: {maze.rows * maze.cell_size + 0.1}
  width: {maze.cols * maze.cell_size + 0.1}
  step_time: 0.1
  sample_time: 0.1
  offset: [-0.05, -0.05]
  collision_mode: 'stop'
robot:
  - kinematics: {{name: 'diff'}}
    shape: {{name: 'circle', radius: 0.037}}
    state: [{start[0]}, {start[1]}, 0]
    vel_max: [0.13, 4.9]
    sensors:
      - type: 'lidar2d'
        range_min: 0.0
        range_max: 0.8
        angle_range: {2 * np.pi}
        number: 180
obstacle:
{obstacles}
"""
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "maze_world.yaml"
        path.write_text(world)
        env = irsim.make(str(path), display=False, log_level="ERROR")
        rng = np.random.default_rng(0)
        actions = [np.array([[rng.uniform(-0.13, 0.13)], [rng.uniform(-4.9, 4.9)]]) for _ in range(steps)]
        began = clock()
        for action in actions:
            env.step(action=action)
        return steps / (clock() - began)


def run() -> dict:
    maze = generate_maze(ROWS, COLS, 0)
    ours = mazeslam_rate(maze)
    theirs, skipped = irsim_comparison(maze)
    row = {
        "benchmark": f"env steps/s, 180 beams, {ROWS}x{COLS} maze",
        "mazeslam_steps_per_s": ours,
        "target": TARGET_RATE,
    }
    if theirs is not None:
        row.update({"irsim_steps_per_s": theirs, "ratio": ours / theirs})
    else:
        row["irsim"] = f"skipped: {skipped}"
    row["met"] = ours >= TARGET_RATE and (theirs is None or ours / theirs >= TARGET_RATIO)
    return row


if __name__ == "__main__":
    import pandas as pd

    print(pd.DataFrame([run()]).set_index("benchmark").to_markdown(floatfmt=".4g"))
    print(f"rates per second of {clock_name()}")
