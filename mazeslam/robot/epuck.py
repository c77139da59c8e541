"""The e-puck over a serial line (pyserial), speaking its ASCII command protocol.

Commands end with a carriage return; the robot answers with the command letter in lower case,
then its values, then CR LF:

    D,left,right   set the wheel speeds, steps/s (1000 steps = one wheel turn)   -> d
    Q              read the wheels' step counters                               -> q,left,right
    P,0,0          set the step counters to 0, 0                               -> p
    S              stop                                                         -> s

Odometry comes from the step counters: each wheel's travel is its steps x 2 pi R / 1000, and
dX = (left + right) / 2, dTheta = (right - left) / wheelbase, with R and the wheelbase from the
robot's config. A command without an answer within ``timeout`` seconds, an answer that is not the
expected one, or a port that fails raise ``RobotError`` / ``RobotDisconnected`` naming the port
and the command.
"""

from __future__ import annotations

import math

import numpy as np

from mazeslam.robot.interface import Robot, RobotDisconnected, RobotError
from mazeslam.sim.world import RobotParams

#: The e-puck's speed command is limited to +-1000 steps/s.
MAX_STEPS_PER_SECOND = 1000


class EPuck(Robot):
    """The e-puck's wheels and odometry on serial port ``port``; a scanner supplies the scans.

    Args:
        port: e.g. ``/dev/ttyUSB0`` (or an open pyserial-like object with read_until/write).
        scanner: a callable returning one scan (e.g. an ``OmniCamera``), or None.
        robot: wheel radius, wheelbase, steps per revolution.
    """

    def __init__(
        self, port, scanner=None, robot: RobotParams | None = None, baudrate: int = 115200, timeout: float = 0.5
    ):
        self.robot = robot or RobotParams()
        self.scanner = scanner
        self.metres_per_step = 2 * math.pi * self.robot.wheel_radius / self.robot.encoder_steps_per_revolution
        if isinstance(port, str):
            import serial

            try:
                self.serial = serial.Serial(port, baudrate=baudrate, timeout=timeout, write_timeout=timeout)
            except (serial.SerialException, OSError) as error:
                raise RobotDisconnected(f"cannot open the e-puck's port {port}: {error}") from error
            self.name = port
        else:
            self.serial, self.name = port, getattr(port, "port", "serial port")
        self._command("P,0,0", "p")
        self._last_counts = (0, 0)

    def _command(self, command: str, reply_letter: str) -> list[str]:
        """Send one command, return the reply's fields after its letter."""
        try:
            self.serial.write((command + "\r").encode("ascii"))
            self.serial.flush()
            line = self.serial.read_until(b"\n")
        except (OSError, Exception) as error:  # pyserial raises SerialException (an OSError subclass) or OSError
            if isinstance(error, RobotError):
                raise
            raise RobotDisconnected(f"e-puck on {self.name} went away during {command!r}: {error}") from error
        if not line:
            raise RobotDisconnected(f"e-puck on {self.name} did not answer {command!r} in time")
        text = line.decode("ascii", errors="replace").strip()
        fields = text.split(",")
        if fields[0] != reply_letter:
            raise RobotError(f"e-puck on {self.name} answered {text!r} to {command!r}, expected {reply_letter!r}...")
        return fields[1:]

    def set_wheel_speeds(self, left: float, right: float) -> None:
        steps = [
            int(np.clip(round(v / self.metres_per_step), -MAX_STEPS_PER_SECOND, MAX_STEPS_PER_SECOND))
            for v in (left, right)
        ]
        self._command(f"D,{steps[0]},{steps[1]}", "d")

    def read_counts(self) -> tuple[int, int]:
        fields = self._command("Q", "q")
        try:
            left, right = (int(v) for v in fields)
        except ValueError as error:
            raise RobotError(f"e-puck on {self.name} sent step counts {fields!r}, expected two integers") from error
        return left, right

    def read_odometry(self) -> tuple[float, float]:
        counts = self.read_counts()
        left, right = ((now - before) * self.metres_per_step for now, before in zip(counts, self._last_counts))
        self._last_counts = counts
        return 0.5 * (left + right), (right - left) / self.robot.wheelbase

    def read_scan(self) -> np.ndarray:
        if self.scanner is None:
            raise RobotError("no scanner (camera) attached to this e-puck")
        return self.scanner()

    def close(self) -> None:
        try:
            self._command("S", "s")
        except RobotError:
            pass  # already gone: nothing to stop
        finally:
            close = getattr(self.serial, "close", None)
            if close is not None:
                close()
