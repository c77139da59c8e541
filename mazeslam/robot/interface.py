"""What the recorder, teleoperation and agents need from a robot, real or simulated.

A ``Robot`` drives its wheels, reports its odometry since the last report, and scans. Errors are
``RobotError`` (the robot answered something it should not) or ``RobotDisconnected`` (it is gone);
both name the device and what happened. Implementations: the e-puck's serial driver
(``mazeslam.robot.epuck.EPuck``) and the simulator (``mazeslam.robot.simulated.SimulatedRobot``).
"""

from __future__ import annotations

import abc

import numpy as np


class RobotError(RuntimeError):
    """The robot or its sensor answered something it should not (garbled, out of protocol)."""


class RobotDisconnected(RobotError):
    """The robot or its sensor stopped answering or went away."""


class Robot(abc.ABC):
    """A differential-drive robot with odometry and a range scanner."""

    @abc.abstractmethod
    def set_wheel_speeds(self, left: float, right: float) -> None:
        """Command the wheels' surface speeds, m/s (forward positive)."""

    @abc.abstractmethod
    def read_odometry(self) -> tuple[float, float]:
        """Distance travelled (m) and heading change (rad) since the previous call."""

    @abc.abstractmethod
    def read_scan(self) -> np.ndarray:
        """One scan: (N,) ranges in metres in the log's beam order, 0 = no return."""

    def close(self) -> None:  # noqa: B027  (optional hook: nothing to release by default)
        """Stop and release the device."""

    def advance(self, seconds: float) -> bool:
        """Let ``seconds`` pass. A real robot moves on its own; the simulator moves here. Returns
        whether the robot touched a wall meanwhile, if it can tell (a real robot cannot: False)."""
        return False
