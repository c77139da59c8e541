"""Simulated wheel encoders and the odometry they report (the exercise's dX, dTheta).

The e-puck's wheels are stepper motors: its "encoder" counts are the steps it was commanded to
make. The ground under a wheel does not follow exactly: each wheel slips, randomly and (if
configured) systematically. So the true motion is the commanded wheel travel plus slip, while the
odometry integrates the commanded steps, quantised to whole steps. Between two odometry records:

    dX     = (left + right) / 2          metres, mean wheel travel
    dTheta = (right - left) / wheelbase  radians

with the nominal wheel radius and wheelbase, as the exercise's logger computes them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mazeslam.config import require
from mazeslam.envs.world import RobotParams


@dataclass(frozen=True)
class OdometryParams:
    """Wheel slip that makes odometry differ from the true motion.

    Attributes:
        slip_std: random slip of each wheel, metres per square root of metre travelled: over a
            wheel travel d the slip has standard deviation ``slip_std * sqrt(|d|)``.
        left_scale_error, right_scale_error: systematic relative error of each wheel's true
            travel (e.g. 0.01: the wheel covers 1 % more ground than its steps say).
    """

    slip_std: float = 0.003
    left_scale_error: float = 0.0
    right_scale_error: float = 0.0

    def __post_init__(self):
        require(self.slip_std >= 0, f"odometry slip_std must be >= 0, got {self.slip_std}")
        for name in ("left_scale_error", "right_scale_error"):
            require(abs(getattr(self, name)) < 0.5, f"odometry {name} must be within +-0.5, got {getattr(self, name)}")


class WheelEncoders:
    """Counts commanded wheel steps and turns them into odometry increments."""

    def __init__(self, robot: RobotParams, params: OdometryParams, rng: np.random.Generator):
        self.robot = robot
        self.params = params
        self.rng = rng
        self.metres_per_step = 2 * np.pi * robot.wheel_radius / robot.encoder_steps_per_revolution
        self._commanded = np.zeros(2)  # left, right commanded travel, metres, since the start
        self._reported_steps = np.zeros(2, dtype=np.int64)

    def drive(self, left_speed: float, right_speed: float, dt: float) -> tuple[float, float]:
        """Command wheel speeds (m/s) for ``dt`` s; returns the wheels' true ground travel (m, m)."""
        commanded = np.array([left_speed, right_speed]) * dt
        self._commanded += commanded
        p = self.params
        scale = 1.0 + np.array([p.left_scale_error, p.right_scale_error])
        slip = self.rng.normal(0.0, 1.0, 2) * p.slip_std * np.sqrt(np.abs(commanded)) if p.slip_std else 0.0
        left, right = commanded * scale + slip
        return float(left), float(right)

    @property
    def steps(self) -> np.ndarray:
        """Whole steps (left, right) the wheels were commanded since the start: the step counters."""
        return np.floor(self._commanded / self.metres_per_step + 1e-9).astype(np.int64)

    def read(self) -> tuple[float, float]:
        """The odometry since the previous read: (dX metres, dTheta radians)."""
        steps = self.steps
        left, right = (steps - self._reported_steps) * self.metres_per_step
        self._reported_steps = steps
        return 0.5 * (left + right), (right - left) / self.robot.wheelbase
