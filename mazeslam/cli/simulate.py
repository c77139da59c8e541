"""``mazeslam simulate``: drive the simulated e-puck through a maze and write a course log with its
truth and map sidecars (and, with ``--plot``, a figure of the run)."""

from __future__ import annotations

from pathlib import Path

import click

from mazeslam.cli.options import BEAMS, DURATION, MAZE_SIDE, SEED
from mazeslam.core.config import with_settings
from mazeslam.core.outputs import prepare_output_file
from mazeslam.data import log, sidecars


@click.command()
@click.option(
    "--out",
    "out",
    type=click.Path(dir_okay=False, path_type=Path),
    required=True,
    help="Log file to write, e.g. runs/demo.log; sidecars go beside it.",
)
@click.option("--seed", type=SEED, default=0, show_default=True, help="Seeds every random draw.")
@click.option(
    "--maze", "maze", default="random", show_default=True, help="'random' or a maze text file (see configs/mazes/)."
)
@click.option("--rows", type=MAZE_SIDE, help="Rows of a random maze.")
@click.option("--cols", type=MAZE_SIDE, help="Columns of a random maze.")
@click.option(
    "--duration", type=DURATION, help="Seconds to simulate [default: until the exploration tour is complete]."
)
@click.option("--beams", type=BEAMS, help="Beams per scan (the exercise's N).")
@click.option(
    "--config",
    "config_path",
    type=click.Path(exists=True, dir_okay=False, path_type=Path),
    help="Simulator TOML config (see configs/simulation.toml).",
)
@click.option(
    "--commands",
    "commands_path",
    type=click.Path(exists=True, dir_okay=False, path_type=Path),
    help="Drive open-loop from a file of 'duration speed turn_rate' lines instead of exploring.",
)
@click.option(
    "--plot",
    "plot_path",
    type=click.Path(dir_okay=False, path_type=Path),
    help="Draw the run: walls, true corners, true path and dead reckoning.",
)
@click.option("--quiet", is_flag=True, help="No progress bar.")
def simulate(out, seed, maze, rows, cols, duration, beams, config_path, commands_path, plot_path, quiet):
    """Drive the simulated e-puck through a maze and write a course log with truth and map sidecars."""
    from mazeslam.sim.policies import load_commands
    from mazeslam.sim.simulator import load_config, too_short_problem
    from mazeslam.sim.simulator import simulate as run_simulation

    config = _with_overrides(load_config(config_path), rows=rows, cols=cols, beams=beams)
    too_short = None if duration is None else too_short_problem(duration, config.logger)
    if too_short:  # refused before any file is written
        raise click.BadParameter(too_short, param_hint="'--duration'")
    policy = load_commands(commands_path) if commands_path else None
    prepare_output_file(out)
    if plot_path:
        prepare_output_file(plot_path)
    result = run_simulation(
        out, config=config, maze=maze, seed=seed, duration=duration, policy=policy, progress=not quiet
    )
    click.echo(
        f"wrote {result.log_path} ({len(result.times)} records, {result.times[-1]:.1f} s simulated), "
        f"{result.truth_path}, {result.map_path}"
    )
    if plot_path:
        click.echo(f"figure: {_plot_simulation(result, plot_path)}")
    if duration is None and not result.policy_finished:
        click.echo(
            f"warning: the run stopped at max_duration {config.max_duration} s before its policy finished", err=True
        )


def _plot_simulation(result, plot_path: Path) -> Path:
    from mazeslam.core.motion import dead_reckoning
    from mazeslam.viz.plots import plot_run

    world = sidecars.read_map(result.map_path)
    estimate = dead_reckoning(log.read(result.log_path), world["start_pose"])
    return plot_run(
        plot_path,
        world["walls"],
        world["corners"],
        result.poses,
        {"dead reckoning": estimate},
        title=f"{result.maze.name}: {len(result.times)} records, {result.times[-1]:.0f} s",
    )


def _with_overrides(config, rows=None, cols=None, beams=None):
    """``config`` with the command-line overrides that were given."""
    try:
        return with_settings(config, {"maze.rows": rows, "maze.cols": cols, "laser.beams": beams})
    except ValueError as error:
        raise click.BadParameter(str(error), param_hint="--rows/--cols/--beams") from error
