"""``mazeslam record``: the recorder on a real e-puck with its camera, or on the simulator."""

from __future__ import annotations

import dataclasses
import math
import sys
from pathlib import Path

import click

from mazeslam.cli.options import (
    BEAMS,
    DURATION,
    FINITE,
    POSITIVE,
    RATE,
    SEED,
    beam_geometry_options,
    geometry_overrides,
)
from mazeslam.core.beams import EXERCISE_CONVENTION
from mazeslam.core.config import with_changes
from mazeslam.core.mirror import EXERCISE_ALPHA, EXERCISE_HEIGHT
from mazeslam.core.outputs import prepare_output_file
from mazeslam.robot.recorder import KeyboardController, Recorder, ScriptedController
from mazeslam.robot.simulated import SimulatedRobot
from mazeslam.sim.maze import generate_maze, load_maze
from mazeslam.sim.policies import load_commands
from mazeslam.sim.simulator import SimulationConfig


@click.command()
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
@click.option("--height", type=POSITIVE, default=EXERCISE_HEIGHT, show_default=True, help="Mirror model h, metres.")
@click.option(
    "--alpha", type=POSITIVE, default=EXERCISE_ALPHA, show_default=True, help="Mirror model alpha, pixels/radian."
)
@click.option("--threshold", default="180", show_default=True, help="Wall grey level (1-255) or 'otsu'.")
@click.option(
    "--script",
    "script",
    type=click.Path(exists=True, dir_okay=False, path_type=Path),
    help="Drive from 'duration speed turn_rate' lines instead of the keyboard: seconds, forward speed in m/s, "
    "turn rate in rad/s (counter-clockwise positive), '#' comments; e.g. '4.0 0.05 0.0' drives 4 s ahead at "
    "5 cm/s, '1.5 0 1.0' turns 1.5 rad in place.",
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
        geometry_overrides=dataclasses.asdict(geometry_overrides(first_beam_angle, beam_direction, mount_x)),
    )
    click.echo("\n".join(lines))


def run_record(
    out,
    port=None,
    camera=None,
    sim=False,
    maze="random",
    seed=0,
    beams=180,
    scan_period=0.75,
    odometry_rate=5.0,
    center=None,
    inner_radius=40.0,
    outer_radius=None,
    height=EXERCISE_HEIGHT,
    alpha=EXERCISE_ALPHA,
    threshold="180",
    script=None,
    duration=None,
    geometry_overrides=None,
) -> list[str]:
    """Record one log; returns the lines to print."""
    geometry = with_changes(EXERCISE_CONVENTION, **(geometry_overrides or {}))
    config = SimulationConfig()
    if sim:
        config = dataclasses.replace(config, laser=dataclasses.replace(config.laser, beams=beams, geometry=geometry))
        chosen = generate_maze(config.maze.rows, config.maze.cols, seed) if maze == "random" else load_maze(maze)
        robot = SimulatedRobot(chosen, config, seed)
    else:
        if not port or camera is None:
            raise ValueError("give --port and --camera for the real e-puck, or --sim for the simulator")
        robot = _real_robot(
            port, camera, geometry, beams, center, inner_radius, outer_radius, height, alpha, threshold, config
        )
    controller = _controller(script, config)
    recorder = Recorder(robot, out, beams, geometry, scan_period, odometry_rate, config.robot.wheelbase)
    interactive = isinstance(controller, KeyboardController)
    try:
        records = recorder.run(controller, duration or math.inf, _status if interactive else None)
    finally:
        if interactive:
            controller.close()
        robot.close()
    stopped = f" (stopped by {recorder.stopped_by})" if recorder.stopped_by else ""
    return [
        f"wrote {out}: {records} records{stopped}; map sidecar with the beam geometry"
        + (" and truth sidecar" if sim else "")
    ]


def _real_robot(port, camera, geometry, beams, center, inner_radius, outer_radius, height, alpha, threshold, config):
    import cv2

    from mazeslam.core.mirror import CameraCalibration
    from mazeslam.robot.epuck import EPuck
    from mazeslam.robot.omnicam import OmniCamera, detect_mirror

    capture = cv2.VideoCapture(int(camera) if str(camera).isdigit() else camera)
    if center is None or outer_radius is None:
        ok, frame = capture.read()
        if not ok:
            raise ValueError(f"camera {camera!r} returned no frame to find the mirror in")
        found_x, found_y, found_radius = detect_mirror(frame)
        center = center or (found_x, found_y)
        outer_radius = outer_radius or 0.95 * found_radius
    calibration = CameraCalibration(
        center[0],
        center[1],
        inner_radius,
        outer_radius,
        height,
        alpha,
        "otsu" if threshold == "otsu" else int(threshold),
    )
    return EPuck(port, OmniCamera(capture, calibration, geometry, beams), config.robot)


def _controller(script, config):
    if script is not None:
        return ScriptedController(load_commands(script).commands)
    if not sys.stdin.isatty():
        raise ValueError("no terminal to drive from: give --script FILE ('duration speed turn_rate' lines)")
    return KeyboardController(config.robot.max_wheel_speed, 2 * config.robot.max_wheel_speed / config.robot.wheelbase)


def _status(t, command, records) -> None:
    sys.stdout.write(
        f"\rt {t:7.1f} s  speed {command.speed:+.3f} m/s  turn {command.turn_rate:+.2f} rad/s  "
        f"records {records}   (w/s speed, a/d turn, space stop, q quit)"
    )
    sys.stdout.flush()
