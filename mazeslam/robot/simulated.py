"""The ``Robot`` interface over the simulator, for the recorder, the e-puck emulator and the
Gymnasium environment."""

from __future__ import annotations

import numpy as np

from mazeslam.robot.interface import Robot
from mazeslam.sim.laser import VirtualLaser
from mazeslam.sim.maze import Maze
from mazeslam.sim.odometry import WheelEncoders
from mazeslam.sim.simulator import SimulationConfig
from mazeslam.sim.walls import wall_geometry
from mazeslam.sim.world import World


class SimulatedRobot(Robot):
    """The ``Robot`` interface over the simulator: pymunk world, slipping wheels, virtual laser.

    Time passes only in ``advance``, in physics steps, so a recorder can drive it as fast as the
    computer allows. ``pose`` is the true pose (for truth sidecars).
    """

    def __init__(
        self,
        maze: Maze,
        config: SimulationConfig | None = None,
        seed: int = 0,
        start_pose: np.ndarray | None = None,
        rng: np.random.Generator | None = None,
    ):
        self.config = config or SimulationConfig()
        self.maze = maze
        self.walls = wall_geometry(maze)
        self.rng = rng if rng is not None else np.random.default_rng(seed)
        self.start_pose = np.array(start_pose if start_pose is not None else [*maze.cell_center(*maze.start_cell), 0.0])
        self.world = World(self.walls.boxes, self.config.robot, self.start_pose)
        self.encoders = WheelEncoders(self.config.robot, self.config.odometry, self.rng)
        self.laser = VirtualLaser(self.config.laser, self.walls.surfaces)
        self.speeds = (0.0, 0.0)
        self.time = 0.0
        self._dt = 1.0 / self.config.logger.physics_rate

    @property
    def pose(self) -> np.ndarray:
        return self.world.pose

    def set_wheel_speeds(self, left: float, right: float) -> None:
        top = self.config.robot.max_wheel_speed
        self.speeds = (min(max(float(left), -top), top), min(max(float(right), -top), top))

    def advance(self, seconds: float) -> bool:
        """Let ``seconds`` of physics pass at the current wheel speeds; return whether the robot
        touched a wall meanwhile."""
        touched = False
        for left, right in self.encoders.drive_steps(*self.speeds, self._dt, max(0, round(seconds / self._dt))):
            touched |= self.world.step(left, right, self._dt)
            self.time += self._dt
        return touched

    def read_odometry(self) -> tuple[float, float]:
        return self.encoders.read()

    def true_ranges(self) -> np.ndarray:
        """Noise-free ranges (N,) from the current pose, inf beyond the laser's range."""
        return self.laser.true_ranges(self.world.pose)

    def read_scan(self, true_ranges: np.ndarray | None = None) -> np.ndarray:
        """A noisy scan (from ``true_ranges`` when already cast)."""
        return self.laser.measure(self.true_ranges() if true_ranges is None else true_ranges, self.rng)
