"""The exercise's logger (Main.m / RobotGUI) as code: drive a robot, write a course log.

``Recorder.run`` polls a controller for (speed, turn rate) commands, drives the robot's wheels,
writes an odometry record every ``1 / odometry_rate`` s (F_O_U) and a scan every ``scan_period`` s
(T_b_S) with an odometry record just before it, and flushes every record. If the robot or its
camera goes away, the log written so far stays valid (every line complete), its sidecar is
written, and ``RobotDisconnected`` is raised saying how many records were saved.

Nothing recorded is lost when the recording is killed: the map sidecar (the beam geometry, and for
a simulated robot the walls) is written before the first record, and a simulated robot's true pose
is appended to the truth sidecar, flushed, just before each record's log line (so a recording
killed between the two leaves one extra pose, which ``load_run`` drops). SIGTERM and SIGINT end
the recording cleanly after the record in progress (``Recorder.stopped_by`` names the signal).

Time comes from ``clock`` and passes in ``wait``: wall time and ``time.sleep`` for a real robot,
the simulator's own clock and ``SimulatedRobot.advance`` for a simulated one (as fast as it can go).
"""

from __future__ import annotations

import math
import signal
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mazeslam.core.beams import BeamGeometry
from mazeslam.data import sidecars
from mazeslam.data.log import LogWriter
from mazeslam.robot.interface import Robot, RobotDisconnected, RobotError
from mazeslam.robot.simulated import SimulatedRobot


@dataclass
class Command:
    """What a controller asks for: forward speed (m/s), turn rate (rad/s), or to stop recording."""

    speed: float = 0.0
    turn_rate: float = 0.0
    quit: bool = False


class ScriptedController:
    """Commands from a list of ``(duration s, speed m/s, turn_rate rad/s)``; quits after the last."""

    def __init__(self, commands):
        self.ends = np.cumsum([c[0] for c in commands])
        self.commands = [tuple(float(v) for v in c) for c in commands]

    def __call__(self, t: float) -> Command:
        index = int(np.searchsorted(self.ends, t, side="right"))
        if index >= len(self.commands):
            return Command(quit=True)
        return Command(self.commands[index][1], self.commands[index][2])


class KeyboardController:
    """The GUI's two sliders on the keyboard: w/s faster/slower, a/d turn left/right, space stop,
    q quit. Reads the terminal without waiting (raw mode, restored on close)."""

    SPEED_STEP, TURN_STEP = 0.01, 0.25  # m/s, rad/s per key press

    def __init__(self, max_speed: float, max_turn_rate: float):
        import termios
        import tty

        self.max_speed, self.max_turn = max_speed, max_turn_rate
        self.command = Command()
        self._fd = sys.stdin.fileno()
        self._saved = termios.tcgetattr(self._fd)
        tty.setcbreak(self._fd)

    def __call__(self, t: float) -> Command:
        import os
        import select

        keys = ""
        while select.select([self._fd], [], [], 0)[0]:  # every key pressed since the last call
            chunk = os.read(self._fd, 64)
            if not chunk:
                break
            keys += chunk.decode("ascii", errors="ignore").lower()
        for key in keys:
            c = self.command
            if key == "w":
                c.speed = min(c.speed + self.SPEED_STEP, self.max_speed)
            elif key == "s":
                c.speed = max(c.speed - self.SPEED_STEP, 0.0)  # forward only, as the GUI's slider
            elif key == "a":
                c.turn_rate = min(c.turn_rate + self.TURN_STEP, self.max_turn)
            elif key == "d":
                c.turn_rate = max(c.turn_rate - self.TURN_STEP, -self.max_turn)
            elif key == " ":
                c.speed = c.turn_rate = 0.0
            elif key == "q":
                c.quit = True
        return self.command

    def close(self) -> None:
        import termios

        termios.tcsetattr(self._fd, termios.TCSADRAIN, self._saved)


class Recorder:
    """Drives ``robot`` and writes ``out`` (course log) and its map sidecar (beam geometry);
    for a ``SimulatedRobot`` also the truth sidecar and the walls."""

    def __init__(
        self,
        robot: Robot,
        out: str | Path,
        beams: int,
        geometry: BeamGeometry,
        scan_period: float = 0.75,
        odometry_rate: float = 5.0,
        wheelbase: float = 0.053,
        clock=None,
        wait=None,
    ):
        if scan_period <= 0 or odometry_rate <= 0:
            raise ValueError("scan_period and odometry_rate must be positive")
        self.robot, self.out, self.beams, self.geometry = robot, Path(out), beams, geometry
        self.scan_period, self.odometry_period = scan_period, 1.0 / odometry_rate
        self.wheelbase = wheelbase
        self.clock: Callable[[], float]
        self.wait: Callable[[float], object]
        if isinstance(robot, SimulatedRobot):
            simulated = robot
            self.clock = clock or (lambda: simulated.time)
            self.wait = wait or simulated.advance
        else:
            self.clock = clock or time.monotonic
            self.wait = wait or time.sleep
        self.records = 0
        self.stopped_by: str | None = None
        self._truth: sidecars.TruthWriter | None = None

    def run(self, controller, duration: float = math.inf, status=None) -> int:
        """Record until the controller quits or ``duration`` s pass; returns the records written."""
        writer = LogWriter(self.out, self.beams)
        self._write_map()
        if isinstance(self.robot, SimulatedRobot):
            self._truth = sidecars.TruthWriter(sidecars.truth_path(self.out))
        previous = self._catch_signals()
        start = self.clock()
        next_odometry, next_scan = self.odometry_period, self.scan_period
        try:
            while True:
                t = self.clock() - start
                command = controller(t)
                if command.quit or t >= duration or self.stopped_by is not None:
                    break
                half = 0.5 * command.turn_rate * self.wheelbase
                self.robot.set_wheel_speeds(command.speed - half, command.speed + half)
                event = min(next_odometry, next_scan)
                self.wait(max(0.0, event - (self.clock() - start)))
                t = round(event, 6)
                scan_due = next_scan <= event + 1e-9
                self._write_odometry(writer, t)
                next_odometry = event + self.odometry_period if next_odometry <= event + 1e-9 else next_odometry
                if scan_due:
                    ranges = self.robot.read_scan()
                    self._note(t)
                    writer.write_scan(t, ranges)
                    next_scan = event + self.scan_period
                if status is not None:
                    status(t, command, self.records)
        except RobotDisconnected as error:
            raise RobotDisconnected(
                f"{error}; the log {self.out} keeps the {self.records} records written before it"
            ) from error
        finally:
            self._restore_signals(previous)
            writer.close()
            if self._truth is not None:
                self._truth.close()
            try:
                self.robot.set_wheel_speeds(0.0, 0.0)
            except RobotError:
                pass  # gone: nothing left to stop
        return self.records

    def _write_odometry(self, writer: LogWriter, t: float) -> None:
        distance, turn = self.robot.read_odometry()
        self._note(t)
        writer.write_odometry(t, distance, turn)

    def _note(self, t: float) -> None:
        """Count a record about to be written; its true pose goes to the truth sidecar first."""
        self.records += 1
        if self._truth is not None and isinstance(self.robot, SimulatedRobot):
            self._truth.write(t, self.robot.pose)

    def _catch_signals(self) -> dict:
        """SIGTERM and SIGINT set ``stopped_by`` (the loop ends after the record in progress);
        returns the handlers to restore. Only the main thread can set handlers: elsewhere, none."""
        if threading.current_thread() is not threading.main_thread():
            return {}

        def stop(number, frame):
            self.stopped_by = signal.Signals(number).name

        return {number: signal.signal(number, stop) for number in (signal.SIGTERM, signal.SIGINT)}

    @staticmethod
    def _restore_signals(previous: dict) -> None:
        for number, handler in previous.items():
            signal.signal(number, handler)

    def _write_map(self) -> None:
        """The map sidecar, before the first record: the beam geometry (and a simulated robot's walls)."""
        sensor = {"beams": self.beams, **self.geometry.to_dict()}
        if isinstance(self.robot, SimulatedRobot):
            walls = self.robot.walls
            sidecars.write_map(
                sidecars.map_path(self.out),
                walls.surfaces,
                walls.corners,
                sensor,
                corner_convex=walls.corner_convex.tolist(),
                start_pose=self.robot.start_pose.tolist(),
                source="mazeslam record --sim",
            )
        else:
            sidecars.write_map(
                sidecars.map_path(self.out),
                np.empty((0, 4)),
                np.empty((0, 2)),
                sensor,
                source="mazeslam record (real robot: no ground truth)",
            )
