"""A software e-puck on a pseudo-terminal: the serial protocol of ``mazeslam.robot.epuck``, with
the simulator's world behind it. Lets the driver, odometry and recorder run without hardware.

``EPuckEmulator(robot)`` opens a pty, serves commands from a thread and exposes ``port`` (the
slave's device name) for ``EPuck(port)``. The simulated robot moves in simulated time: every
command advances it by ``seconds_per_command`` (so tests are fast and repeatable). ``garble`` makes
it answer nonsense; ``close()`` pulls the plug.
"""

from __future__ import annotations

import os
import threading

import numpy as np

from mazeslam.core.geometry import transform_points
from mazeslam.core.mirror import CameraCalibration
from mazeslam.robot.omnicam import render_view
from mazeslam.robot.simulated import SimulatedRobot
from mazeslam.sim.laser import RayCaster


class EPuckEmulator:
    def __init__(self, robot: SimulatedRobot, seconds_per_command: float = 0.02):
        self.robot = robot
        self.seconds_per_command = seconds_per_command
        self.garble = False
        self.commands = 0
        self._master, self._slave = os.openpty()
        self.port = os.ttyname(self._slave)
        self._zero = robot.encoders.steps.copy()  # counters read 0 here (P,0,0 moves it)
        self._running = True
        self._thread = threading.Thread(target=self._serve, daemon=True)
        self._thread.start()

    def _serve(self) -> None:
        buffer = b""
        while self._running:
            try:
                chunk = os.read(self._master, 256)
            except OSError:
                return
            if not chunk:
                return
            buffer += chunk
            while b"\r" in buffer:
                line, buffer = buffer.split(b"\r", 1)
                reply = self._answer(line.decode("ascii", errors="replace").strip())
                try:
                    os.write(self._master, reply.encode("ascii") + b"\r\n")
                except OSError:
                    return

    def _answer(self, command: str) -> str:
        self.commands += 1
        if self.garble:
            return "#@!"
        robot = self.robot
        per_step = robot.encoders.metres_per_step
        robot.advance(self.seconds_per_command)  # the world moves on at the current speeds
        counts = robot.encoders.steps - self._zero
        fields = command.split(",")
        letter = fields[0].upper()
        if letter == "D" and len(fields) == 3:
            robot.set_wheel_speeds(int(fields[1]) * per_step, int(fields[2]) * per_step)
            return "d"
        if letter == "Q":
            return f"q,{counts[0]},{counts[1]}"
        if letter == "P" and len(fields) == 3:
            self._zero = robot.encoders.steps - [int(fields[1]), int(fields[2])]
            return "p"
        if letter == "S":
            robot.set_wheel_speeds(0.0, 0.0)
            return "s"
        return f"z,unknown command {command!r}"

    def close(self) -> None:
        """Pull the plug: the driver's next command finds no robot."""
        self._running = False
        for fd in (self._master, self._slave):
            try:
                os.close(fd)
            except OSError:
                pass


class RenderedCamera:
    """Omnidirectional camera frames rendered from the simulated robot's true pose (white floor,
    dark walls, the mirror model of ``calibration``), with VideoCapture's ``read()``."""

    def __init__(self, robot: SimulatedRobot, calibration: CameraCalibration, size: int, angles: int = 2880):
        self.robot, self.calibration, self.size = robot, calibration, size
        self.angles = np.linspace(-np.pi, np.pi, angles, endpoint=False)
        self.caster = RayCaster(robot.walls.surfaces, self.angles, 10.0)
        self.frames = 0

    def read(self):
        self.frames += 1
        pose = self.robot.pose
        sensor_x, sensor_y = transform_points(pose, self.robot.laser.mount)
        ranges = self.caster.cast(float(sensor_x), float(sensor_y), float(pose[2]))
        return True, render_view(ranges, self.angles, self.calibration, self.size)
