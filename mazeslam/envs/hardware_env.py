"""The Gymnasium environment on a real robot: the simulator's actions and observations, wall time."""

from __future__ import annotations

import time

import numpy as np

from mazeslam.envs.drive_env import DriveEnv
from mazeslam.robot.interface import Robot
from mazeslam.sim.simulator import SimulationConfig


class HardwareMazeEnv(DriveEnv):
    """A real robot (``EPuck(...)``, any ``mazeslam.robot.interface.Robot``) in place of the
    simulator, for agents trained on ``mazeslam/Maze-v0``.

    ## Actions and observations
    As ``DriveEnv`` (and ``mazeslam/Maze-v0``): (speed, turn rate) or (left, right) wheel speeds in
    [-1, 1], with the robot's limits from ``config.robot``; the robot's scan (``config.laser.beams``
    ranges) and the step's odometry increment. A step commands the wheels, lets ``control_period``
    seconds of wall time pass, then reads the odometry and one scan.

    ## Rewards
    0: there is no ground truth to reward exploration by.

    ## Starting state
    Wherever the robot stands: ``reset`` forgets the odometry so far and scans.

    ## Episode end
    Never terminated; truncated after ``max_steps`` steps.

    ## Info
    ``time``: seconds of wall time into the episode (``control_period`` per step).

    The caller owns ``robot``: closing the environment leaves it connected.
    """

    def __init__(
        self,
        robot: Robot,
        config: SimulationConfig | None = None,
        max_steps: int = 3000,
        control_period: float = 0.1,
        action_type: str = "velocity",
    ):
        super().__init__(config, max_steps, control_period, action_type)
        self.robot = robot

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        self.steps, self.time = 0, 0.0
        self.robot.read_odometry()  # forget the motion before the episode
        self.last_scan = np.asarray(self.robot.read_scan(), dtype=np.float32)
        return self._observation(), {"time": self.time}

    def step(self, action):
        self.robot.set_wheel_speeds(*self._command(action))
        time.sleep(self.control_period)
        self.time += self.control_period
        distance, turn = self.robot.read_odometry()
        self.last_scan = np.asarray(self.robot.read_scan(), dtype=np.float32)
        return self._observation(distance, turn), 0.0, False, self.steps >= self.max_steps, {"time": self.time}
