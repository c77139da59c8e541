"""``mazeslam corners``: the lines and corners extracted from a log's scans, summarised, drawn
(one scan, an animation, a live window) or written as JSON."""

from __future__ import annotations

from pathlib import Path

import click

from mazeslam.cli.options import beam_geometry_options, geometry_overrides
from mazeslam.core.outputs import prepare_output_file


@click.command()
@click.argument("log_file", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option(
    "--scan",
    "scan_number",
    type=click.IntRange(min=0),
    default=0,
    show_default=True,
    help="Which scan to draw (0 = the log's first scan).",
)
@click.option(
    "--plot",
    "plot_path",
    type=click.Path(dir_okay=False, path_type=Path),
    help="Draw that scan: points, lines in colours, corners in green (PNG/PDF/SVG).",
)
@click.option(
    "--animate",
    "animation_path",
    type=click.Path(dir_okay=False, path_type=Path),
    help="Draw every scan into an animation (GIF).",
)
@click.option(
    "--json",
    "json_path",
    type=click.Path(dir_okay=False, path_type=Path),
    help="Write every scan's lines and observations as JSON.",
)
@click.option(
    "--config",
    "config_path",
    type=click.Path(exists=True, dir_okay=False, path_type=Path),
    help="A slam config whose [corners] to use (configs/course.toml, configs/carmen.toml, ...), "
    "or a file of [corners] settings alone.",
)
@click.option(
    "--mode",
    type=click.Choice(["corners", "endpoints"]),
    help="corners: fixed landmarks only; endpoints: every segment end (the exercise).",
)
@click.option(
    "--live",
    is_flag=True,
    help="Show each scan as it is processed in a window (points, lines, corners, the robot), --max-fps scans "
    "a second; without a display, says so (use --plot or --animate).",
)
@click.option(
    "--max-fps",
    type=click.FloatRange(min=0.1),
    default=10.0,
    show_default=True,
    help="With --live: frames a second (in a window every scan is shown at this rate).",
)
@beam_geometry_options
def corners(
    log_file,
    scan_number,
    plot_path,
    animation_path,
    json_path,
    config_path,
    mode,
    live,
    max_fps,
    first_beam_angle,
    beam_direction,
    mount_x,
):
    """Extract lines and corners from a log's scans (course log or CARMEN log)."""
    from mazeslam.viz.corner_report import CornerReport

    for written in (plot_path, animation_path, json_path):
        if written:
            prepare_output_file(written)
    sensor = geometry_overrides(first_beam_angle, beam_direction, mount_x)
    view = None
    if live:
        from mazeslam.data.scans import load_scans
        from mazeslam.viz.live import CornersLiveView

        view = CornersLiveView(load_scans(log_file, sensor), max_fps=max_fps)
        if view.message:
            click.echo(view.message, err=True)
    report = CornerReport.from_log(log_file, config_path, mode, sensor, on_scan=view)
    if view is not None:
        view.close(report)
        click.echo(
            f"Live view: {view.frames} frames drawn in {view.drawing_seconds:.1f} s"
            + ("" if view.window else " (off-screen: no display)")
        )
    click.echo(report.summary())
    warning = report.convention_warning()
    if warning:
        click.echo(warning)
    if plot_path:
        click.echo(f"figure: {report.plot(scan_number, plot_path)}")
    if animation_path:
        click.echo(f"animation: {report.animate(animation_path)}")
    if json_path:
        click.echo(f"json: {report.write_json(json_path)}")
