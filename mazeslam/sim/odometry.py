"""Simulated wheel encoders and the odometry they report (the exercise's dX, dTheta).

The e-puck's wheels are stepper motors: its "encoder" counts are the steps it was commanded to
make. The ground under a wheel does not follow exactly: each wheel slips, randomly and (if
configured) systematically. So the true motion is the commanded wheel travel plus slip, while the
odometry integrates the commanded steps, quantised to whole steps. Between two odometry records:

    dX     = (left + right) / 2          metres, mean wheel travel
    dTheta = (right - left) / wheelbase  radians

with the nominal wheel radius and wheelbase, as the exercise's logger computes them.

The course robot's logger also writes glitches (``OdometryGlitches``): records off by a jump far
beyond any real motion, which the exercise drops with its jump tolerance TOL_JMP.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mazeslam.core.config import require
from mazeslam.sim.world import RobotParams


@dataclass(frozen=True)
class OdometryParams:
    """Wheel slip that makes odometry differ from the true motion.

    Attributes:
        slip_std: random slip of each wheel, metres per square root of metre travelled: over a
            wheel travel d the slip has standard deviation ``slip_std * sqrt(|d|)``.
        left_scale_error, right_scale_error: systematic relative error of each wheel's true
            travel (e.g. 0.01: the wheel covers 1 % more ground than its steps say).
        glitch_rate: probability that an odometry record starts a glitch (``OdometryGlitches``);
            0: none.
        glitch_pair_share: share of the glitches that come as a pair of records (the rest are
            lone jumps).
        glitch_distance: dX (m) a pair's first record reports beyond the motion; a lone jump
            reports ``-2 glitch_distance``.
        glitch_turn: dTheta (rad) a pair's first record reports beyond the motion, either sign.
    """

    slip_std: float = 0.003
    left_scale_error: float = 0.0
    right_scale_error: float = 0.0
    glitch_rate: float = 0.0
    glitch_pair_share: float = 0.67
    glitch_distance: float = 0.0603
    glitch_turn: float = 0.849

    def __post_init__(self):
        require(self.slip_std >= 0, f"odometry slip_std must be >= 0, got {self.slip_std}")
        for name in ("left_scale_error", "right_scale_error"):
            require(abs(getattr(self, name)) < 0.5, f"odometry {name} must be within +-0.5, got {getattr(self, name)}")
        for name in ("glitch_rate", "glitch_pair_share"):
            require(0 <= getattr(self, name) <= 1, f"odometry {name} must be in [0, 1], got {getattr(self, name)}")
        require(
            0 <= self.glitch_distance <= 10,
            f"odometry glitch_distance must be in [0, 10] m, got {self.glitch_distance}",
        )
        require(0 <= self.glitch_turn <= 10, f"odometry glitch_turn must be in [0, 10] rad, got {self.glitch_turn}")


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
        ((left, right),) = self.drive_steps(left_speed, right_speed, dt, 1)
        return left, right

    def drive_steps(self, left_speed: float, right_speed: float, dt: float, steps: int) -> list[list[float]]:
        """Command wheel speeds (m/s) for ``steps`` physics steps of ``dt`` s each; returns each
        step's true ground travel of the wheels, [[left m, right m], ...]: the same numbers as
        ``steps`` calls of ``drive`` (the slip of all the steps drawn at once, in the same order)."""
        commanded = np.array([left_speed, right_speed]) * dt
        for _ in range(steps):
            self._commanded += commanded
        p = self.params
        scale = 1.0 + np.array([p.left_scale_error, p.right_scale_error])
        slip = self.rng.normal(0.0, 1.0, (steps, 2)) * p.slip_std * np.sqrt(np.abs(commanded)) if p.slip_std else 0.0
        return np.broadcast_to(commanded * scale + slip, (steps, 2)).tolist()

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


class OdometryGlitches:
    """Corrupts odometry records as the course robot's logger does (log1's three glitches).

    A wheel's step counter is misread by a fixed jump (in log1, 256 counts: one byte):

    - a **pair**: one wheel's counter reads too high for one record and right again at the next, so
      the first record reports ``(+glitch_distance, +-glitch_turn)`` beyond the motion and the next
      one the same back; the two records sum to the true motion (log1: dX +0.065 then -0.057,
      dTheta +0.85 then -0.85, twice);
    - a **lone** jump: both counters jump back for good, so one record reports
      ``-2 glitch_distance`` beyond the motion and no turn (log1: dX -0.119).

    A glitch starts at a record with probability ``glitch_rate`` (none while a pair is open); the
    truth is untouched.
    """

    def __init__(self, params: OdometryParams, rng: np.random.Generator):
        self.params = params
        self.rng = rng
        self._open_pair: tuple[float, float] | None = None  # (dX, dTheta) to take back at the next record

    def apply(self, distance: float, turn: float) -> tuple[float, float, str | None]:
        """The record ``(dX m, dTheta rad)`` the logger writes for the odometry of one interval, and
        what was done to it: ``"pair_first"``, ``"pair_second"``, ``"lone"`` or None (nothing)."""
        p = self.params
        if self._open_pair is not None:
            jump_distance, jump_turn = self._open_pair
            self._open_pair = None
            return distance - jump_distance, turn - jump_turn, "pair_second"
        if not p.glitch_rate or self.rng.random() >= p.glitch_rate:
            return distance, turn, None
        if self.rng.random() < p.glitch_pair_share:
            self._open_pair = (p.glitch_distance, p.glitch_turn * self.rng.choice((-1.0, 1.0)))
            return distance + self._open_pair[0], turn + self._open_pair[1], "pair_first"
        return distance - 2 * p.glitch_distance, turn, "lone"
