"""``mazeslam calibrate``: a log's noise (laser range, odometry, corner observations) measured as
filter settings, over one log or several together."""

from __future__ import annotations

from pathlib import Path

import click

from mazeslam.cli.options import beam_geometry_options, geometry_overrides
from mazeslam.core.outputs import prepare_output_file


@click.command()
@click.argument("log_files", nargs=-1, required=True, type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option(
    "--config",
    "config_path",
    type=click.Path(exists=True, dir_okay=False, path_type=Path),
    help="A slam config: its corner settings, scan matching and (without truth) the filter run.",
)
@click.option(
    "--write",
    "write_path",
    type=click.Path(dir_okay=False, path_type=Path),
    help="Also write the settings to this TOML file.",
)
@beam_geometry_options
@click.option("--quiet", is_flag=True, help="No progress bar.")
def calibrate(log_files, config_path, write_path, first_beam_angle, beam_direction, mount_x, quiet):
    """Measure a log's noise (laser range, odometry, corner observations) as filter settings:
    against the truth beside it when there is one, else against the filter's own path and map.
    Several logs (one robot's, one dataset's) give one setting for them all, every noise fitted
    over all of them together."""
    from mazeslam.calibration.noise import calibrate_logs
    from mazeslam.data.beam_detection import loaded_with_convention
    from mazeslam.pipeline import load_slam_config

    if write_path:
        prepare_output_file(write_path)
    config = load_slam_config(config_path)
    config = config.with_sensor(geometry_overrides(first_beam_angle, beam_direction, mount_x))
    runs = [loaded_with_convention(log_file, config) for log_file in log_files]
    try:
        lines = calibrate_logs(runs, config, progress=not quiet).settings()
    except ValueError as error:
        raise click.ClickException(str(error)) from error  # it names the log
    text = "\n".join(lines) + "\n"
    click.echo(text, nl=False)
    if write_path:
        write_path.write_text(text)
        click.echo(f"wrote {write_path}")
