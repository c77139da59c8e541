"""The main job on built-in defaults: simulate a maze run, run FastSLAM on it, print the ATE table, plot."""

from __future__ import annotations

from pathlib import Path

from mazeslam.envs.simulator import SimulationConfig, simulate
from mazeslam.slam_command import run_slam_command


def run_demo(
    out_dir: str | Path = "runs/demo", seed: int = 0, config: SimulationConfig | None = None, progress: bool = True
) -> list[str]:
    """Simulate ``out_dir``/run.log, then FastSLAM into ``out_dir``/slam/; return the lines to print."""
    out_dir = Path(out_dir)
    result = simulate(out_dir / "run.log", config=config, seed=seed, progress=progress)
    lines = [f"simulated {result.maze.name} (seed {seed}): {result.log_path}, {result.truth_path}, {result.map_path}"]
    return lines + run_slam_command(result.log_path, None, out_dir / "slam", progress=progress)
