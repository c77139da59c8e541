"""``mazeslam info``: validate a course log and print a summary of it (records, time, beams, odometry
travel, sidecars), and with ``--detect-beams`` the beam convention its scans agree on."""

from __future__ import annotations

from pathlib import Path

import click

from mazeslam.cli.options import FINITE, course_log_expected
from mazeslam.data import log


@click.command()
@click.argument("log_file", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("--lenient", is_flag=True, help="Skip bad lines and report them instead of stopping.")
@click.option(
    "--detect-beams",
    is_flag=True,
    help="Find the beam convention (first-beam angle, direction) from how consecutive scans agree.",
)
@click.option(
    "--config",
    "config_path",
    type=click.Path(exists=True, dir_okay=False, path_type=Path),
    help="With --detect-beams: a slam TOML whose [corners] ranges, [odometry] jump tolerance and "
    "[sensor] mount_x to use (e.g. configs/course.toml).",
)
@click.option("--mount-x", type=FINITE, help="With --detect-beams: sensor ahead of the wheel axle [m].")
def info(log_file, lenient, detect_beams, config_path, mount_x):
    """Validate a course log and print a summary: records, duration, beams, odometry travel."""
    with course_log_expected(log_file):
        course_log = log.read(log_file, strict=not lenient)
    facts = log.summary(course_log)
    click.echo(f"{facts['source']}: valid course log")
    click.echo(
        f"  records           {facts['records']} ({facts['odometry_records']} odometry, "
        f"{facts['scan_records']} scans, {facts['landmark_records']} landmark observations)"
    )
    click.echo(f"  time              {facts['duration_s']:.3f} s long, from {facts['start_s']:.3f} s")
    click.echo(f"  beams per scan    {facts['beams'] if facts['beams'] is not None else 'no scans'}")
    click.echo(
        f"  odometry travel   {facts['distance_m']:.3f} m, turned {facts['total_rotation_rad']:.3f} rad "
        f"in all (net {facts['net_rotation_rad']:+.3f} rad)"
    )
    if facts["odometry_records"]:
        longest, metres = course_log.longest_step()
        click.echo(f"  longest step      {metres:.3f} m ({course_log.line_of(longest)})")
    if facts["scan_records"]:
        click.echo(
            f"  ranges            max {facts['max_range_m']:.3f} m, {100 * facts['no_return_fraction']:.1f} % no return"
        )
    _echo_sidecars(log_file)
    for skipped in course_log.skipped:
        click.echo(f"  skipped line {skipped.line}: {skipped.reason}")
    if course_log.skipped:
        click.echo(f"  {len(course_log.skipped)} line(s) skipped")
    if detect_beams:
        from mazeslam.data.beam_detection import describe, detect_beam_convention
        from mazeslam.pipeline import load_slam_config

        config = load_slam_config(config_path)
        mount = mount_x if mount_x is not None else (config.sensor.mount_x or 0.0)
        detection = detect_beam_convention(
            course_log, mount, config.corners.min_range, config.corners.max_range, config.odometry.jump_tolerance
        )
        click.echo("\n".join(describe(detection)))


def _echo_sidecars(log_file: Path) -> None:
    """Name the truth and map sidecars beside a log, and the beam geometry the map records."""
    from mazeslam.data import sidecars

    truth, world = sidecars.truth_path(log_file), sidecars.map_path(log_file)
    click.echo(f"  ground truth      {truth if truth.exists() else 'none'}")
    sensor = sidecars.read_map(world)["sensor"] if world.exists() else None
    if sensor is not None and "kind" in sensor:
        click.echo(f"  map               {world}: sensor {sensor['kind']}")
    elif sensor is not None:
        geometry = sidecars.beam_geometry(sensor)
        click.echo(
            f"  map               {world}: beam 0 at {geometry.first_beam_angle:+.4f} rad, "
            f"{'counter-clockwise' if geometry.direction > 0 else 'clockwise'}, "
            f"sensor at ({geometry.mount_x:.3f}, {geometry.mount_y:.3f}) m"
        )
    else:
        click.echo("  map               none (beam convention not recorded)")
