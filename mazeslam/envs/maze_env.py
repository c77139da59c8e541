"""``mazeslam/Maze-v0``: drive the simulated e-puck through a maze and get rewarded for exploring.

Observation (a Dict):
    ``scan``      Box(0, max_range, (N,)) the virtual laser's ranges in beam order, metres, 0 = no
                  return (what a course log's scan record holds).
    ``odometry``  Box((2,)) the step's odometry increment: distance travelled (m), heading change
                  (rad) - the course log's dX, dTheta.
Action: Box(-1, 1, (2,)): ``action_type="velocity"`` gives (forward speed, turn rate) as fractions of
the robot's top speed and top turn rate; ``"wheels"`` gives (left, right) wheel speeds as fractions
of the top wheel speed.
Reward: ``wall_reward`` per metre of wall surface seen for the first time, plus ``cell_reward`` per
cell entered for the first time, minus ``collision_penalty`` for each step that touches a wall.
Episode end: terminated when every cell has been visited; truncated after ``max_steps`` steps.
Mazes: random R x C mazes drawn at every reset, perfect by default (``loop_fraction=0``: one path
between any two cells), or a given ``Maze`` / maze file; ``reset(options=...)`` may override
``maze``, ``rows``, ``cols``, ``loop_fraction``, ``start_cell`` and ``start_heading``.

A real robot (``robot=EPuck(...)``, any ``mazeslam.robot.interface.Robot``) can stand in for the
simulator: the same observations and actions, each step lasting ``control_period`` of wall time;
with no ground truth there is no reward (0), no termination and ``info`` holds only the time.
``info``: the true ``pose`` (x, y, theta), ``coverage`` (share of the wall surface seen),
``visited`` (share of cells entered), ``collision``, ``time`` (s).

One step lasts ``control_period`` seconds of simulated time (physics at the config's rate), and
ends with one scan. Every random draw (maze, start, wheel slip, laser noise) comes from
``self.np_random``, seeded by ``reset(seed=...)``.
"""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from scipy.spatial import cKDTree

from mazeslam.envs.maze import Maze, generate_maze, load_maze
from mazeslam.envs.simulated_robot import SimulatedRobot
from mazeslam.envs.simulator import SimulationConfig
from mazeslam.robot.interface import Robot

#: Spacing (m) of the points along the walls that count as seen once a beam lands near them.
WALL_SAMPLE_SPACING = 0.01


class MazeEnv(gym.Env):
    metadata = {"render_modes": ["human", "rgb_array"], "render_fps": 10}

    def __init__(self, render_mode: str | None = None, config: SimulationConfig | None = None, rows: int = 4,
                 cols: int = 4, maze: Maze | str | None = None, loop_fraction: float = 0.0, max_steps: int = 3000,
                 control_period: float = 0.1,
                 action_type: str = "velocity", wall_reward: float = 10.0, cell_reward: float = 1.0,
                 collision_penalty: float = 0.5, robot: Robot | None = None):
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode must be one of {self.metadata['render_modes']} or None, got {render_mode!r}")
        if action_type not in ("velocity", "wheels"):
            raise ValueError(f"action_type must be 'velocity' or 'wheels', got {action_type!r}")
        if max_steps < 1 or control_period <= 0:
            raise ValueError("max_steps must be >= 1 and control_period positive")
        self.render_mode = render_mode
        self.hardware = robot
        self.config = config or SimulationConfig()
        self.rows, self.cols, self.maze_option, self.loop_fraction = rows, cols, maze, loop_fraction
        self.max_steps = max_steps
        self.control_period = control_period
        self.action_type = action_type
        self.wall_reward, self.cell_reward, self.collision_penalty = wall_reward, cell_reward, collision_penalty
        robot, laser = self.config.robot, self.config.laser
        self.physics_steps = max(1, round(control_period * self.config.logger.physics_rate))
        self.top_turn_rate = 2 * robot.max_wheel_speed / robot.wheelbase  # rad/s, wheels opposite at top speed
        reach = 2.0 * robot.max_wheel_speed * control_period  # odometry bound, with room for slip
        self.observation_space = spaces.Dict({
            "scan": spaces.Box(0.0, laser.max_range, shape=(laser.beams,), dtype=np.float32),
            "odometry": spaces.Box(np.array([-reach, -reach * 2 / robot.wheelbase], dtype=np.float32),
                                   np.array([reach, reach * 2 / robot.wheelbase], dtype=np.float32)),
        })
        self.action_space = spaces.Box(-1.0, 1.0, shape=(2,), dtype=np.float32)
        self.maze = None
        self._figure = None

    # -- episode ------------------------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        options = options or {}
        self.steps, self.time = 0, 0.0
        if self.hardware is not None:
            self.hardware.read_odometry()  # forget the motion before the episode
            self.last_scan = np.asarray(self.hardware.read_scan(), dtype=np.float32)
            return {"scan": self.last_scan, "odometry": np.zeros(2, dtype=np.float32)}, {"time": 0.0}
        self.maze = self._choose_maze(options)
        start_cell = tuple(options.get("start_cell", (int(self.np_random.integers(self.maze.rows)),
                                                      int(self.np_random.integers(self.maze.cols)))))
        heading = float(options.get("start_heading", self.np_random.uniform(-math.pi, math.pi)))
        self.start_pose = np.array([*self.maze.cell_center(*start_cell), heading])
        self.simulated = SimulatedRobot(self.maze, self.config, start_pose=self.start_pose, rng=self.np_random)
        self.walls, self.laser = self.simulated.walls, self.simulated.laser
        self._samples = _wall_samples(self.walls.surfaces)
        self._sample_tree = cKDTree(self._samples)
        self.seen = np.zeros(len(self._samples), dtype=bool)
        self.visited = np.zeros((self.maze.rows, self.maze.cols), dtype=bool)
        self.visited[self.maze.cell_of(*self.start_pose[:2])] = True
        self._see()
        observation = {"scan": self.last_scan, "odometry": np.zeros(2, dtype=np.float32)}
        return observation, self._info(collision=False)

    def _choose_maze(self, options: dict) -> Maze:
        choice = options.get("maze", self.maze_option)
        if isinstance(choice, Maze):
            return choice
        if choice is not None and str(choice) != "random":
            return load_maze(choice)
        rows, cols = options.get("rows", self.rows), options.get("cols", self.cols)
        p = self.config.maze
        return generate_maze(rows, cols, self.np_random, p.cell_size, p.wall_thickness,
                             options.get("loop_fraction", self.loop_fraction))

    def step(self, action):
        if self.maze is None and self.hardware is None:
            raise RuntimeError("call reset() before step()")
        left, right = self._wheel_speeds(np.clip(np.asarray(action, dtype=float), -1.0, 1.0))
        self.steps += 1
        if self.hardware is not None:
            return self._hardware_step(left, right)
        self.simulated.set_wheel_speeds(left, right)
        collision = self.simulated.advance(self.physics_steps / self.config.logger.physics_rate)
        self.time = self.simulated.time
        distance, turn = self.simulated.read_odometry()
        pose = self.simulated.pose
        new_cell = not self.visited[self.maze.cell_of(*pose[:2])]
        self.visited[self.maze.cell_of(*pose[:2])] = True
        newly_seen = self._see()
        reward = (self.wall_reward * newly_seen * WALL_SAMPLE_SPACING + self.cell_reward * new_cell
                  - self.collision_penalty * collision)
        terminated = bool(self.visited.all())
        truncated = self.steps >= self.max_steps
        observation = {"scan": self.last_scan, "odometry": np.array([distance, turn], dtype=np.float32)}
        if self.render_mode == "human":
            self.render()
        return observation, float(reward), terminated, truncated, self._info(collision)

    def _hardware_step(self, left: float, right: float):
        """One step on a real robot: command, let ``control_period`` of wall time pass, observe."""
        import time

        self.hardware.set_wheel_speeds(left, right)
        time.sleep(self.control_period)
        self.time += self.control_period
        distance, turn = self.hardware.read_odometry()
        self.last_scan = np.asarray(self.hardware.read_scan(), dtype=np.float32)
        observation = {"scan": self.last_scan, "odometry": np.array([distance, turn], dtype=np.float32)}
        return observation, 0.0, False, self.steps >= self.max_steps, {"time": self.time}

    @property
    def world(self):
        """The simulated robot's pymunk world (its ``pose`` is the truth)."""
        return self.simulated.world

    def _wheel_speeds(self, action: np.ndarray) -> tuple[float, float]:
        robot = self.config.robot
        if self.action_type == "wheels":
            return float(action[0]) * robot.max_wheel_speed, float(action[1]) * robot.max_wheel_speed
        return robot.wheel_speeds(float(action[0]) * robot.max_wheel_speed, float(action[1]) * self.top_turn_rate)

    def _see(self) -> int:
        """Scan (into ``last_scan``) and mark the wall samples its noise-free beams land on; return
        how many are new."""
        pose = self.simulated.pose
        ranges = self.simulated.true_ranges()
        self.last_scan = self.simulated.read_scan(ranges).astype(np.float32)
        hit = np.isfinite(ranges)
        geometry = self.config.laser
        c, s = math.cos(pose[2]), math.sin(pose[2])
        sensor = pose[:2] + (c * geometry.mount_x - s * geometry.mount_y, s * geometry.mount_x + c * geometry.mount_y)
        angles = pose[2] + self.laser.bearings[hit]
        points = sensor + ranges[hit, None] * np.column_stack([np.cos(angles), np.sin(angles)])
        _, nearest = self._sample_tree.query(points, distance_upper_bound=WALL_SAMPLE_SPACING)
        nearest = nearest[nearest < len(self._samples)]
        before = int(self.seen.sum())
        self.seen[nearest] = True
        return int(self.seen.sum()) - before

    def _info(self, collision: bool) -> dict:
        return {"pose": self.world.pose, "coverage": float(self.seen.mean()), "visited": float(self.visited.mean()),
                "collision": bool(collision), "time": self.time}

    # -- rendering ----------------------------------------------------------------------------
    def render(self):
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; pass render_mode='rgb_array' or 'human'")
            return None
        from mazeslam.envs.rendering import draw_maze_env

        if self.render_mode == "rgb_array":
            return draw_maze_env(self)
        import matplotlib.pyplot as plt

        image = draw_maze_env(self)
        if self._figure is None:
            plt.ion()
            self._figure = plt.figure("mazeslam/Maze-v0")
        self._figure.clf()
        self._figure.add_subplot(111).imshow(image)
        plt.pause(1.0 / self.metadata["render_fps"])
        return None

    def close(self):
        if self._figure is not None:
            import matplotlib.pyplot as plt

            plt.close(self._figure)
            self._figure = None


def _wall_samples(surfaces: np.ndarray) -> np.ndarray:
    """Points every ``WALL_SAMPLE_SPACING`` metres along each wall surface (S, 2)."""
    chunks = []
    for x1, y1, x2, y2 in surfaces:
        count = max(1, int(round(math.hypot(x2 - x1, y2 - y1) / WALL_SAMPLE_SPACING)))
        t = (np.arange(count) + 0.5) / count
        chunks.append(np.column_stack([x1 + t * (x2 - x1), y1 + t * (y2 - y1)]))
    return np.concatenate(chunks)
