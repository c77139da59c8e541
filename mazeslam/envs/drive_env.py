"""What every mazeslam Gymnasium environment shares: drive the e-puck, observe its scans and odometry."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from mazeslam.sim.simulator import SimulationConfig


class DriveEnv(gym.Env):
    """Drive a differential-drive robot (the e-puck) step by step and observe what a course log
    holds: its laser scan and its odometry. The variants (``MazeEnv``: the simulator,
    ``HardwareMazeEnv``: a real robot) add the rewards, the episode's end and ``info``.

    ## Action space
    ``Box(-1, 1, (2,), float32)``, clipped to [-1, 1], as fractions of the robot's limits:

    | ``action_type`` | ``action[0]``                      | ``action[1]``                                       |
    |-----------------|------------------------------------|-----------------------------------------------------|
    | ``"velocity"``  | forward speed / top wheel speed    | turn rate / top turn rate (2 top speed / wheelbase) |
    | ``"wheels"``    | left wheel speed / top wheel speed | right wheel speed / top wheel speed                 |

    A velocity command that would drive a wheel past its top speed is scaled down as a whole
    (the path's curvature is kept). An action of another shape, or with a NaN or infinite value (a
    diverging policy), is refused with a ``ValueError`` naming the action and the space.

    ## Observation space
    ``Dict``:

    | key          | space                                | meaning                                              |
    |--------------|--------------------------------------|------------------------------------------------------|
    | ``scan``     | ``Box(0, max_range, (N,), float32)`` | laser ranges in beam order, metres, 0 = no return    |
    | ``odometry`` | ``Box((2,), float32)``               | the step's odometry increment: distance travelled    |
    |              |                                      | (m), heading change (rad); zeros at reset            |

    ``scan`` is a course log's scan record; ``odometry`` is the log's dX, dTheta.

    ``N`` and ``max_range`` are ``config.laser.beams`` and ``config.laser.max_range``; the
    odometry bounds are twice what the top wheel speed allows in one step (room for slip).

    ## Steps and truncation
    One step lasts ``control_period`` seconds and ends with one scan. An episode is truncated
    after ``max_steps`` steps.
    """

    def __init__(
        self,
        config: SimulationConfig | None = None,
        max_steps: int = 3000,
        control_period: float = 0.1,
        action_type: str = "velocity",
    ):
        if action_type not in ("velocity", "wheels"):
            raise ValueError(f"action_type must be 'velocity' or 'wheels', got {action_type!r}")
        if max_steps < 1 or control_period <= 0:
            raise ValueError("max_steps must be >= 1 and control_period positive")
        self.config = config or SimulationConfig()
        self.max_steps = max_steps
        self.control_period = control_period
        self.action_type = action_type
        robot, laser = self.config.robot, self.config.laser
        self.top_turn_rate = 2 * robot.max_wheel_speed / robot.wheelbase  # rad/s, wheels opposite at top speed
        reach = 2.0 * robot.max_wheel_speed * control_period  # odometry bound, with room for slip
        self.observation_space = spaces.Dict(
            {
                "scan": spaces.Box(0.0, laser.max_range, shape=(laser.beams,), dtype=np.float32),
                "odometry": spaces.Box(
                    np.array([-reach, -reach * 2 / robot.wheelbase], dtype=np.float32),
                    np.array([reach, reach * 2 / robot.wheelbase], dtype=np.float32),
                ),
            }
        )
        self.action_space = spaces.Box(-1.0, 1.0, shape=(2,), dtype=np.float32)
        self.steps: int | None = None  # steps into the episode; None before the first reset
        self.time = 0.0  # seconds into the episode
        self.last_scan: np.ndarray | None = None  # (N,) float32, the latest observation's scan

    def _command(self, action) -> tuple[float, float]:
        """Count a step and turn its action into (left, right) wheel speeds, m/s."""
        if self.steps is None:
            raise RuntimeError("call reset() before step()")
        first, second = (min(max(value, -1.0), 1.0) for value in checked_actions(action, self.action_space).tolist())
        self.steps += 1
        robot = self.config.robot
        if self.action_type == "wheels":
            return first * robot.max_wheel_speed, second * robot.max_wheel_speed
        return robot.wheel_speeds(first * robot.max_wheel_speed, second * self.top_turn_rate)

    def _observation(self, distance: float = 0.0, turn: float = 0.0) -> dict:
        """The observation: ``last_scan`` and the odometry increment (m, rad)."""
        return {"scan": self.last_scan, "odometry": np.array([distance, turn], dtype=np.float32)}


def checked_actions(actions, space: spaces.Space, name: str = "action") -> np.ndarray:
    """``actions`` as a float64 array of ``space``'s shape, every value finite; a ``ValueError``
    naming them and the space otherwise (a NaN would otherwise reach the physics and the ray cast).
    Finite values outside ``space``'s bounds are kept: the envs clip them."""
    try:
        given = np.asarray(actions)
        if np.iscomplexobj(given):  # numpy would drop the imaginary parts, with a warning
            raise TypeError("complex numbers")
        values = given.astype(np.float64)
    except (TypeError, ValueError, OverflowError) as error:  # OverflowError: an integer beyond any float
        raise ValueError(f"{name} {_shown(actions)} is not an array of numbers: the action space is {space}") from error
    if values.shape != space.shape:
        raise ValueError(
            f"{name} of shape {values.shape} does not fit the action space {space}: it takes shape {space.shape}"
        )
    finite = np.isfinite(values)
    if not finite.all():
        if values.ndim == 2:  # a vector env's actions: name the envs
            rows = np.flatnonzero(~finite.all(axis=1))
            envs = ", ".join(map(str, rows[:10])) + (", ..." if len(rows) > 10 else "")
            what = f"{name} of env{'s' if len(rows) > 1 else ''} {envs}, {_shown(values[rows[:3]].tolist())}, have"
        else:
            what = f"{name} {_shown(values.tolist())} has"
        raise ValueError(
            f"{what} a NaN or infinite value: actions must be finite, in {space} "
            f"(finite values outside its bounds are clipped)"
        )
    return values


def _shown(value, limit: int = 80) -> str:
    """``repr(value)`` on one line (a numpy array's spans several), cut to ``limit`` characters."""
    text = " ".join(repr(value).split())
    return text if len(text) <= limit else text[: limit - 3] + "..."
