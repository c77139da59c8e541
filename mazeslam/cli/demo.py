"""``mazeslam demo``: the main job on built-in defaults: simulate a maze run, run FastSLAM on it, print
the ATE table, plot."""

from __future__ import annotations

from pathlib import Path

import click

from mazeslam.cli.options import SEED
from mazeslam.cli.slam import run_slam_command
from mazeslam.core.outputs import prepare_output_folder
from mazeslam.sim.simulator import SimulationConfig, simulate


@click.command()
@click.option(
    "--out",
    "out_dir",
    type=click.Path(file_okay=False, path_type=Path),
    default=Path("runs/demo"),
    show_default=True,
    help="Folder for the log, sidecars, table and figure.",
)
@click.option("--seed", type=SEED, default=0, show_default=True)
@click.option("--quiet", is_flag=True, help="No progress bar.")
def demo(out_dir, seed, quiet):
    """The main job on defaults: simulate a maze run, run FastSLAM, print the ATE table, plot it."""
    prepare_output_folder(out_dir)
    click.echo("\n".join(run_demo(out_dir, seed=seed, progress=not quiet)))


def run_demo(
    out_dir: str | Path = "runs/demo", seed: int = 0, config: SimulationConfig | None = None, progress: bool = True
) -> list[str]:
    """Simulate ``out_dir``/run.log, then FastSLAM into ``out_dir``/slam/; return the lines to print."""
    out_dir = Path(out_dir)
    result = simulate(out_dir / "run.log", config=config, seed=seed, progress=progress)
    lines = [f"simulated {result.maze.name} (seed {seed}): {result.log_path}, {result.truth_path}, {result.map_path}"]
    return lines + run_slam_command(result.log_path, None, out_dir / "slam", progress=progress)
