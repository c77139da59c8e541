"""``mazeslam record``: the recorder on a real e-puck with its camera, or on the simulator."""

from __future__ import annotations

import dataclasses
import math
import sys

from mazeslam.beams import EXERCISE_CONVENTION
from mazeslam.config import with_changes
from mazeslam.envs.maze import generate_maze, load_maze
from mazeslam.envs.policies import load_commands
from mazeslam.envs.simulated_robot import SimulatedRobot
from mazeslam.envs.simulator import SimulationConfig
from mazeslam.robot.recorder import KeyboardController, Recorder, ScriptedController


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
    height=0.126,
    alpha=107.0,
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

    from mazeslam.robot.epuck import EPuck
    from mazeslam.robot.omnicam import CameraCalibration, OmniCamera, detect_mirror

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
