"""The ``mazeslam`` command line: one sub-command per stage (see ``mazeslam --help``).

Built on click: typed options, ``--help`` for every command and clean error reporting without
hand-written argument parsing.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import click

from mazeslam import log
from mazeslam.config import ConfigError, InputError
from mazeslam.options import BEAMS, DURATION, FINITE, MAZE_SIDE, PARTICLES, POSITIVE, RATE, SEED
from mazeslam.outputs import OutputError, prepare_output_file, prepare_output_folder
from mazeslam.robot.interface import RobotError


@click.group()
@click.version_option(package_name="mazeslam")
def main():
    """Particle-filter SLAM (FastSLAM) for a small differential-drive robot in a maze."""


@main.command()
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
    from mazeslam.envs.policies import load_commands
    from mazeslam.envs.simulator import load_config
    from mazeslam.envs.simulator import simulate as run_simulation

    config = _with_overrides(load_config(config_path), rows=rows, cols=cols, beams=beams)
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
    from mazeslam import sidecars
    from mazeslam.evaluation.plots import plot_run
    from mazeslam.filters.motion import dead_reckoning

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
    maze_changes = {k: v for k, v in (("rows", rows), ("cols", cols)) if v is not None}
    try:
        if maze_changes:
            config = dataclasses.replace(config, maze=dataclasses.replace(config.maze, **maze_changes))
        if beams is not None:
            config = dataclasses.replace(config, laser=dataclasses.replace(config.laser, beams=beams))
    except ValueError as error:
        raise click.BadParameter(str(error), param_hint="--rows/--cols/--beams") from error
    return config


@main.command()
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
    course_log = log.read(log_file, strict=not lenient)
    facts = log.summary(course_log)
    click.echo(f"{facts['source']}: valid course log")
    click.echo(
        f"  records           {facts['records']} ({facts['odometry_records']} odometry, "
        f"{facts['scan_records']} scans, {facts['landmark_records']} landmark observations)"
    )
    click.echo(f"  time              {facts['start_s']:.3f} s + {facts['duration_s']:.3f} s")
    click.echo(f"  beams per scan    {facts['beams'] if facts['beams'] is not None else 'no scans'}")
    click.echo(
        f"  odometry travel   {facts['distance_m']:.3f} m, turned {facts['total_rotation_rad']:.3f} rad "
        f"in all (net {facts['net_rotation_rad']:+.3f} rad)"
    )
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
        from mazeslam.beam_detection import describe, detect_beam_convention
        from mazeslam.slam import load_slam_config

        config = load_slam_config(config_path)
        mount = mount_x if mount_x is not None else (config.sensor.mount_x or 0.0)
        detection = detect_beam_convention(
            course_log, mount, config.corners.min_range, config.corners.max_range, config.odometry.jump_tolerance
        )
        click.echo("\n".join(describe(detection)))


def _echo_sidecars(log_file: Path) -> None:
    """Name the truth and map sidecars beside a log, and the beam geometry the map records."""
    from mazeslam import sidecars

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


def beam_geometry_options(function):
    """The options that override a log's beam geometry (for every command that reads scans)."""
    options = [
        click.option("--first-beam-angle", type=FINITE, help="Bearing of beam 0 in the robot frame [rad]."),
        click.option(
            "--beam-direction",
            type=click.Choice(["1", "-1"]),
            help="1: bearings grow counter-clockwise with the beam index; -1: clockwise.",
        ),
        click.option("--mount-x", type=FINITE, help="Sensor ahead of the wheel axle [m] (CAMERA_POS_DX)."),
    ]
    for option in reversed(options):
        function = option(function)
    return function


def _geometry_overrides(first_beam_angle, beam_direction, mount_x):
    """The beam-geometry options as ``SensorOverrides`` (None: not given)."""
    from mazeslam.beams import SensorOverrides

    try:
        return SensorOverrides(
            first_beam_angle=first_beam_angle,
            mount_x=mount_x,
            direction=int(beam_direction) if beam_direction else None,
        )
    except ValueError as error:
        raise click.BadParameter(str(error), param_hint="--first-beam-angle/--mount-x") from error


@main.command()
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
    help="Corner extraction TOML (see configs/corners/).",
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
    from mazeslam.evaluation.corner_report import CornerReport

    for written in (plot_path, animation_path, json_path):
        if written:
            prepare_output_file(written)
    sensor = _geometry_overrides(first_beam_angle, beam_direction, mount_x)
    view = None
    if live:
        from mazeslam.live import CornersLiveView
        from mazeslam.scans import load_scans

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


@main.command()
@click.argument("log_file", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option(
    "--particles",
    type=PARTICLES,
    help="Particle count of the filter that runs [default: from the config; 100 without one].",
)
@click.option(
    "--config",
    "config_path",
    type=click.Path(exists=True, dir_okay=False, path_type=Path),
    help="FastSLAM TOML with [fastslam], [corners], [sensor] (see configs/fastslam.toml).",
)
@click.option(
    "--out",
    "out_dir",
    type=click.Path(file_okay=False, path_type=Path),
    help="Folder for trajectory.csv, map.json, slam.png, occupancy.pgm/.yaml [default: runs/<log name>/slam/ "
    "under the current directory]; a rerun replaces the files of the last run.",
)
@click.option("--seed", type=SEED, help="Seed of the filter's random draws [default: from the config, 0].")
@click.option(
    "--association",
    type=click.Choice(["unknown", "known"]),
    help="unknown: maximum likelihood with a gate; known: the landmark records' identities.",
)
@click.option("--version", "version", type=click.Choice(["1", "2"]), help="FastSLAM 1.0 or 2.0.")
@click.option(
    "--map",
    "map_kind",
    type=click.Choice(["landmarks", "grid"]),
    help="What the particles map [default: the config's [map] kind, landmarks]: landmarks (corner FastSLAM) "
    "or grid (an occupancy grid each, gmapping's filter).",
)
@click.option(
    "--animate",
    is_flag=True,
    help="Also write the run as an animation (particles, map, current scan and corners over time): "
    "slam.mp4 when ffmpeg is available (pip install 'mazeslam[video]'), slam.gif otherwise.",
)
@click.option(
    "--live",
    is_flag=True,
    help="Show the filter as it runs in a window (particles, map, current scan and corners); without a "
    "display, says so (use --animate).",
)
@beam_geometry_options
@click.option("--quiet", is_flag=True, help="No progress bar.")
def slam(
    log_file,
    particles,
    config_path,
    out_dir,
    seed,
    association,
    version,
    map_kind,
    animate,
    live,
    first_beam_angle,
    beam_direction,
    mount_x,
    quiet,
):
    """Run FastSLAM on a course log: trajectory, map, the exercise's figure, and errors when truth exists."""
    from mazeslam.run_folders import SLAM_FILES, clear_outputs, default_out_dir

    overrides = _geometry_overrides(first_beam_angle, beam_direction, mount_x)
    out_dir = prepare_output_folder(out_dir or default_out_dir(log_file, "slam"))
    clear_outputs(out_dir, SLAM_FILES)
    filter_changes = {
        "NPARTICLES": particles,
        "seed": seed,
        "association": association,
        "version": int(version) if version else None,
    }
    from mazeslam.slam_command import run_slam_command

    lines = run_slam_command(
        log_file,
        config_path,
        out_dir,
        filter_changes,
        overrides,
        animate,
        not quiet,
        live=live,
        echo=lambda message: click.echo(message, err=True),
        map_kind=map_kind,
        side_process=True,
    )
    click.echo("\n".join(lines))
    click.echo(f"results in {out_dir}")


@main.command()
@click.argument("log_file", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option(
    "--config",
    "config_path",
    type=click.Path(exists=True, dir_okay=False, path_type=Path),
    help="The slam TOML whose [fastslam] noise, [corners] and [sensor] to use (see configs/fastslam.toml).",
)
@click.option(
    "--association",
    type=click.Choice(["known", "from-run"]),
    default="known",
    show_default=True,
    help="known: the true corners (truth and map sidecars); from-run: the map of a `mazeslam slam` run.",
)
@click.argument("run_dir", required=False, type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.option(
    "--out",
    "out_dir",
    type=click.Path(file_okay=False, path_type=Path),
    help="Folder for trajectory.csv, map.json, smooth.png [default: runs/<log name>/smooth/ under the "
    "current directory]; a rerun replaces the files of the last run.",
)
@beam_geometry_options
def smooth(log_file, config_path, association, run_dir, out_dir, first_beam_angle, beam_direction, mount_x):
    """Batch least-squares SLAM over the whole log: the optimum FastSLAM is measured against.

    With --association from-run, RUN_DIR is the output folder of `mazeslam slam` on the same log."""
    from mazeslam.smooth_command import run_smooth_command

    if (association == "from-run") != (run_dir is not None):
        raise click.UsageError("RUN_DIR goes with --association from-run, and only with it")
    from mazeslam.run_folders import SMOOTH_FILES, clear_outputs, default_out_dir

    out_dir = out_dir or default_out_dir(log_file, "smooth")
    if run_dir is not None and out_dir.resolve() == run_dir.resolve():
        raise click.UsageError("--out is RUN_DIR: the smoother would replace the run it reads; give another folder")
    out_dir = prepare_output_folder(out_dir)
    clear_outputs(out_dir, SMOOTH_FILES)
    overrides = _geometry_overrides(first_beam_angle, beam_direction, mount_x)
    click.echo("\n".join(run_smooth_command(log_file, config_path, out_dir, association, run_dir, overrides)))
    click.echo(f"results in {out_dir}")


@main.command()
@click.option(
    "--out",
    "out",
    type=click.Path(dir_okay=False, path_type=Path),
    required=True,
    help="Course log to write (its map sidecar records the beam geometry).",
)
@click.option("--port", help="The e-puck's serial port, e.g. /dev/ttyUSB0.")
@click.option("--camera", help="Camera device index or video file of the omnidirectional camera.")
@click.option("--sim", is_flag=True, help="Record from the simulator instead (same recorder).")
@click.option("--maze", default="random", show_default=True, help="With --sim: 'random' or a maze file.")
@click.option("--seed", type=SEED, default=0, show_default=True, help="With --sim: the maze's and noise's seed.")
@click.option("--beams", type=BEAMS, default=180, show_default=True, help="N, ranges per scan.")
@click.option("--scan-period", type=DURATION, default=0.75, show_default=True, help="T_b_S, seconds between scans.")
@click.option("--odometry-rate", type=RATE, default=5.0, show_default=True, help="F_O_U, odometry records per second.")
@click.option("--center", nargs=2, type=FINITE, help="Mirror centre in the image, pixels (x y).")
@click.option("--inner-radius", type=FINITE, default=40.0, show_default=True, help="Ring's inner radius, pixels.")
@click.option("--outer-radius", type=FINITE, help="Ring's outer radius, pixels [default: detect the mirror].")
@click.option("--height", type=POSITIVE, default=0.126, show_default=True, help="Mirror model h, metres.")
@click.option("--alpha", type=POSITIVE, default=107.0, show_default=True, help="Mirror model alpha, pixels/radian.")
@click.option("--threshold", default="180", show_default=True, help="Wall grey level (1-255) or 'otsu'.")
@click.option(
    "--script",
    "script",
    type=click.Path(exists=True, dir_okay=False, path_type=Path),
    help="Drive from 'duration speed turn_rate' lines instead of the keyboard.",
)
@click.option("--duration", type=DURATION, help="Stop after this many seconds.")
@beam_geometry_options
def record(
    out,
    port,
    camera,
    sim,
    maze,
    seed,
    beams,
    scan_period,
    odometry_rate,
    center,
    inner_radius,
    outer_radius,
    height,
    alpha,
    threshold,
    script,
    duration,
    first_beam_angle,
    beam_direction,
    mount_x,
):
    """The exercise's logger: drive the e-puck (keyboard: w/s speed, a/d turn, space stop, q quit)
    and record odometry and omnidirectional-camera scans as a course log."""
    from mazeslam.record_command import run_record

    prepare_output_file(out)
    lines = run_record(
        out=out,
        port=port,
        camera=camera,
        sim=sim,
        maze=maze,
        seed=seed,
        beams=beams,
        scan_period=scan_period,
        odometry_rate=odometry_rate,
        center=center,
        inner_radius=inner_radius,
        outer_radius=outer_radius,
        height=height,
        alpha=alpha,
        threshold=threshold,
        script=script,
        duration=duration,
        geometry_overrides=dataclasses.asdict(_geometry_overrides(first_beam_angle, beam_direction, mount_x)),
    )
    click.echo("\n".join(lines))


@main.command()
@click.argument("sweep_file", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option(
    "--out",
    "out_dir",
    type=click.Path(file_okay=False, path_type=Path),
    required=True,
    help="Results folder; runs already in it are not run again (resume).",
)
@click.option("--workers", type=click.IntRange(min=1), help="Local worker processes [default: one per core].")
@click.option("--scheduler", help="Run on the Dask cluster at this address instead, e.g. tcp://host:8786.")
@click.option("--quiet", is_flag=True, help="No progress bar.")
def sweep(sweep_file, out_dir, workers, scheduler, quiet):
    """Run a grid of simulator and filter settings over seeds; write one table and its summary."""
    from mazeslam.evaluation.sweep import load_sweep, run_sweep
    from mazeslam.evaluation.sweep_report import make_report

    definition = load_sweep(sweep_file)
    prepare_output_folder(out_dir)
    result = run_sweep(definition, out_dir, workers, scheduler, progress=not quiet)
    for problem in result.skipped:
        click.echo(f"warning: {problem}", err=True)
    click.echo(
        f"{definition.name}: {len(result.table)} runs ({result.ran} run now in {result.seconds:.1f} s, "
        f"{result.reused} already in {out_dir})"
    )
    click.echo((out_dir / "summary.md").read_text())
    click.echo("wrote " + ", ".join(str(p) for p in [*result.paths.values(), *make_report(out_dir)[1:]]))


@main.command()
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
    from mazeslam.beam_detection import with_detected_convention
    from mazeslam.evaluation.calibration import calibrate_logs
    from mazeslam.loaded_run import load_run
    from mazeslam.slam import load_slam_config

    if write_path:
        prepare_output_file(write_path)
    config = load_slam_config(config_path)
    config = dataclasses.replace(
        config, sensor=_geometry_overrides(first_beam_angle, beam_direction, mount_x).over(config.sensor)
    )
    runs = [with_detected_convention(load_run(log_file, config.sensor), config) for log_file in log_files]
    try:
        lines = calibrate_logs(runs, config, progress=not quiet).settings()
    except ValueError as error:
        raise click.ClickException(str(error)) from error  # it names the log
    text = "\n".join(lines) + "\n"
    click.echo(text, nl=False)
    if write_path:
        write_path.write_text(text)
        click.echo(f"wrote {write_path}")


@main.command(name="odometry-noise")
@click.argument("log_file", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option(
    "--config",
    "config_path",
    type=click.Path(exists=True, dir_okay=False, path_type=Path),
    help="A slam config; with [scan_matching] enabled, the laser odometry is measured instead.",
)
@click.option(
    "--trimmed",
    is_flag=True,
    help="Fit again without the stretches beyond 3 standard deviations of the fit (failed scan matches, "
    "glitches; for laser odometry at least [scan_matching] prior_floor), until none is left out anew; "
    "prints how many were.",
)
def odometry_noise(log_file, config_path, trimmed):
    """Measure a log's odometry noise against its truth sidecar, as [fastslam] settings."""
    from mazeslam.evaluation.odometry_noise import (
        OUTLIER_SIGMAS,
        fit_noise,
        fit_noise_trimmed,
        motion_stretch_errors,
    )
    from mazeslam.filters.scan_matching import laser_odometry
    from mazeslam.loaded_run import load_run
    from mazeslam.slam import load_slam_config

    config = load_slam_config(config_path)
    run = load_run(log_file, config.sensor)
    if run.truth is None:
        raise click.ClickException(
            f"{log_file}: no truth sidecar {run.name}.truth.csv: the noise is measured against it"
        )
    truth_file = f"{run.name}.truth.csv"
    laser = laser_odometry(run.log, run.geometry, config.scan_matching) if config.scan_matching.enabled else None
    source = "laser odometry" if laser is not None else "odometry"
    try:
        errors = motion_stretch_errors(run.log, run.truth, laser)
        floor = config.scan_matching.prior_floor if laser is not None else 0.0
        noise = fit_noise_trimmed(errors, floor) if trimmed else fit_noise(errors)
    except ValueError as error:
        raise click.ClickException(f"{log_file}: {error}") from error
    click.echo(
        f"# {log_file}: {noise.stretches} stretches between observations, {noise.distance:.2f} m driven, "
        f"{noise.turn:.1f} rad turned ({source} against {truth_file})"
    )
    if trimmed:
        click.echo(
            f"# trimmed: {noise.left_out} stretches left out, beyond {OUTLIER_SIGMAS:g} standard deviations of the fit "
            f"(at least {floor:g} m and rad)"
        )
    click.echo("[fastslam]")
    click.echo(f"sigmaX = {noise.noise.sigmaX:.4g}          # m per sqrt(m)")
    click.echo(f"sigmaTH = {noise.noise.sigmaTH:.4g}         # rad per sqrt(rad) turned")
    click.echo(f"sigmaTH_drive = {noise.noise.sigmaTH_drive:.4g}   # rad per sqrt(m) driven")


@main.command()
@click.argument("out_dir", type=click.Path(exists=True, file_okay=False, path_type=Path))
def report(out_dir):
    """Turn a sweep's results folder into Markdown tables and plots."""
    from mazeslam.evaluation.sweep_report import make_report

    click.echo("wrote " + ", ".join(str(p) for p in make_report(out_dir)))


@main.group(name="import")
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
    from mazeslam.imports.mrclam import import_mrclam

    prepare_output_file(out)
    counts = import_mrclam(dataset, robot, out)
    skipped = ", ".join(f"{count} {reason}" for reason, count in counts["skipped"].items()) or "none"
    click.echo(
        f"wrote {out}: {counts['records']} records ({counts['odometry_records']} odometry, "
        f"{counts['landmark_records']} landmark observations); measurements left out: {skipped}"
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
    from mazeslam.imports.carmen import import_carmen

    prepare_output_file(out)
    counts = import_carmen(carmen_log, out)
    click.echo(f"wrote {out}: " + ", ".join(f"{value} {key}" for key, value in counts.items()))


@main.command()
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
    from mazeslam.demo import run_demo

    prepare_output_folder(out_dir)
    click.echo("\n".join(run_demo(out_dir, seed=seed, progress=not quiet)))


@main.command()
@click.argument("trajectory", type=click.Path(exists=True, path_type=Path))
@click.argument("relations_file", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option(
    "--reference",
    type=click.Path(exists=True, path_type=Path),
    help="A second trajectory scored the same way, e.g. the reference poses of `mazeslam import carmen` "
    "(<log>.truth.csv); the ratio of the two is printed.",
)
@click.option(
    "--max-time-gap",
    type=POSITIVE,
    default=0.05,
    show_default=True,
    help="A relation's time must lie this close to a pose's time [s].",
)
def relations(trajectory, relations_file, reference, max_time_gap):
    """Score a trajectory by the relation metric of Kümmerle et al. (2009) against RELATIONS_FILE.

    TRAJECTORY: a `mazeslam slam` output folder (its best_trajectory.csv, else trajectory.csv), a
    trajectory CSV, or a truth CSV (t,x,y,theta).
    RELATIONS_FILE: one relation a line, `t1 t2 x y z roll pitch yaw`: the reference motion from the
    pose at time t1 to the pose at t2, in the first pose's frame (the format of the benchmark's
    hand-verified relations). Each time takes the pose nearest it."""
    from mazeslam.relations_command import relations_lines

    click.echo("\n".join(relations_lines(trajectory, relations_file, reference, max_time_gap)))


#: The errors the command line reports as one line ``error: <message>`` (no traceback): bad input
#: (a log, a config, a maze, a sweep file; a setting out of range), an output that cannot be
#: written, a robot that went away, and any file the system refuses (OSError).
KNOWN_ERRORS = (log.LogFormatError, ConfigError, InputError, OutputError, ValueError, RobotError, OSError)


def exit_status(error: BaseException) -> int:
    """The exit status of a ``KNOWN_ERRORS`` error: 2 for bad input, 1 for an output or the system."""
    return (
        1
        if isinstance(error, (OutputError, PermissionError))
        or (isinstance(error, OSError) and not isinstance(error, FileNotFoundError))
        else 2
    )


def run():
    """Entry point: turn known errors into a one-line message and exit status 2 (bad input) or 1."""
    try:
        main(standalone_mode=True)
    except KNOWN_ERRORS as error:
        click.echo(f"error: {error}", err=True)
        raise SystemExit(exit_status(error)) from error


if __name__ == "__main__":
    run()
