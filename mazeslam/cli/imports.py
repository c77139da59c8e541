"""``mazeslam import``: the group of commands that turn other datasets into course logs with truth
and map sidecars: ``mazeslam import mrclam`` (UTIAS MRCLAM) and ``mazeslam import carmen`` (CARMEN
laser logs)."""

from __future__ import annotations

from pathlib import Path

import click

from mazeslam.core.outputs import prepare_output_file


@click.group(name="import")
def import_group():
    """Turn other datasets into course logs with truth and map sidecars."""


@import_group.command(name="mrclam")
@click.argument("dataset", type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.option("--robot", type=click.IntRange(1, 5), required=True, help="Which of the 5 robots.")
@click.option(
    "--out",
    "out",
    type=click.Path(dir_okay=False, path_type=Path),
    required=True,
    help="Course log to write, e.g. runs/mrclam1.log; sidecars go beside it.",
)
def import_mrclam_command(dataset, robot, out):
    """UTIAS MRCLAM: velocity odometry and barcoded landmark observations, Vicon truth."""
    from mazeslam.data.mrclam import import_mrclam

    prepare_output_file(out)
    counts = import_mrclam(dataset, robot, out)
    skipped = ", ".join(f"{count} {reason}" for reason, count in counts["skipped"].items()) or "none"
    held = counts["outside_truth"]
    reordered = ", ".join(f"{count} of {name}" for name, count in counts["sorted"].items())
    click.echo(
        f"wrote {out}: {counts['records']} records ({counts['odometry_records']} odometry, "
        f"{counts['landmark_records']} landmark observations); measurements left out: {skipped}"
        + (f"; {held} records lie outside the truth's time span and get the pose at its nearer end" if held else "")
        + (f"; rows sorted into time order: {reordered}" if reordered else "")
    )


@import_group.command(name="carmen")
@click.argument("carmen_log", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option(
    "--out",
    "out",
    type=click.Path(dir_okay=False, path_type=Path),
    required=True,
    help="Course log to write, e.g. runs/aces.log; reference poses and sensor sidecars go beside it.",
)
def import_carmen_command(carmen_log, out):
    """A CARMEN laser log (plain or gzipped): front-laser scans, wheel odometry, reference poses."""
    from mazeslam.data.carmen import import_carmen

    prepare_output_file(out)
    counts = import_carmen(carmen_log, out)
    click.echo(f"wrote {out}: " + ", ".join(f"{value} {key}" for key, value in counts.items()))
