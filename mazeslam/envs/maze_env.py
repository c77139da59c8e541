"""``mazeslam/Maze-v0``: drive the simulated e-puck through a maze and get rewarded for exploring."""

from __future__ import annotations

import math
import os
from numbers import Integral, Real

import gymnasium as gym
import numpy as np

from mazeslam.core.geometry import transform_points
from mazeslam.core.limits import maze_problem
from mazeslam.envs.drive_env import DriveEnv
from mazeslam.robot.simulated import SimulatedRobot
from mazeslam.sim.maze import Maze, generate_maze, load_maze
from mazeslam.sim.simulator import MazeParams, SimulationConfig
from mazeslam.sim.walls import WallsInSight

#: Spacing (m) of the points along the walls that count as seen once a beam lands near them.
WALL_SAMPLE_SPACING = 0.01
#: The keys ``reset(options=...)`` takes (the vector env takes ``reset_mask`` too).
RESET_OPTIONS = ("maze", "rows", "cols", "loop_fraction", "start_cell", "start_heading")


class MazeEnv(DriveEnv):
    """``mazeslam/Maze-v0``: the simulated e-puck explores a maze.

    ## Actions and observations
    As ``DriveEnv``: (speed, turn rate) or (left, right) wheel speeds in [-1, 1]; the scan and the
    step's odometry increment. One step lasts ``control_period`` seconds of simulated time (physics
    at ``config.logger.physics_rate``) and ends with one scan.

    ## Rewards
    ``wall_reward`` per metre of wall surface seen for the first time (a noise-free beam landing
    within ``WALL_SAMPLE_SPACING`` of it), plus ``cell_reward`` per cell entered for the first time,
    minus ``collision_penalty`` for each step that touches a wall.

    ## Starting state
    A random R x C maze drawn at every reset, perfect by default (``loop_fraction=0``: one path
    between any two cells; unlike ``mazeslam simulate``, whose random mazes have 15 % of their inner
    walls removed for loops: pass ``loop_fraction=0.15`` for those), or a given ``Maze`` / maze file;
    the robot at the centre of a random cell with a random heading. ``reset(options=...)`` may
    override ``maze``, ``rows``, ``cols``, ``loop_fraction``, ``start_cell`` ((row, col) of a cell
    of the maze) and ``start_heading`` (rad); another key, or a value out of its range, is refused
    with a ``ValueError`` naming the option and its valid range. A maze has at most
    ``mazeslam.core.limits.MAX_MAZE_CELLS`` cells.

    ## Episode end
    Terminated when every cell has been visited. Truncated by Gymnasium's ``TimeLimit``: the
    registration's ``max_episode_steps`` (3000 steps, 300 s simulated; ``gym.make(...,
    max_episode_steps=N)`` to change it, ``env.spec.max_episode_steps`` to read it). ``max_steps``
    (None by default) makes the environment truncate itself too, for use without ``gym.make``.

    ## Info
    | key          | meaning                                   |
    |--------------|-------------------------------------------|
    | ``pose``     | the true pose (x, y, theta): m, m, rad    |
    | ``coverage`` | share of the wall surface seen            |
    | ``visited``  | share of the cells entered                |
    | ``collision``| whether the step touched a wall           |
    | ``time``     | simulated seconds into the episode        |

    Every random draw (maze, start, wheel slip, laser noise) comes from ``self.np_random``, seeded
    by ``reset(seed=...)``.
    """

    metadata = {"render_modes": ["human", "rgb_array"], "render_fps": 10}

    def __init__(
        self,
        render_mode: str | None = None,
        config: SimulationConfig | None = None,
        rows: int = 4,
        cols: int = 4,
        maze: Maze | str | None = None,
        loop_fraction: float = 0.0,
        max_steps: int | None = None,
        control_period: float = 0.1,
        action_type: str = "velocity",
        wall_reward: float = 10.0,
        cell_reward: float = 1.0,
        collision_penalty: float = 0.5,
    ):
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode must be one of {self.metadata['render_modes']} or None, got {render_mode!r}")
        super().__init__(config, max_steps or 1, control_period, action_type)  # checks the settings
        check_maze_settings(
            rows,
            cols,
            maze,
            loop_fraction,
            {"wall_reward": wall_reward, "cell_reward": cell_reward, "collision_penalty": collision_penalty},
        )
        self.max_steps: int | None = max_steps  # type: ignore[assignment]  # None: TimeLimit truncates
        self.render_mode = render_mode
        self.rows, self.cols, self.maze_option, self.loop_fraction = rows, cols, maze, loop_fraction
        self.wall_reward, self.cell_reward, self.collision_penalty = wall_reward, cell_reward, collision_penalty
        self.physics_steps = max(1, round(control_period * self.config.logger.physics_rate))
        self.maze: Maze | None = None  # the episode's maze, from the first reset on
        self._figure = None

    # -- episode ------------------------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        options = episode_options(options, self.maze_option, self.rows, self.cols, self.loop_fraction)
        super().reset(seed=seed)
        self.steps, self.time = 0, 0.0
        maze = choose_maze(
            options, self.maze_option, self.rows, self.cols, self.loop_fraction, self.config.maze, self.np_random
        )
        self.maze = maze
        self.start_pose = draw_start_pose(maze, options, self.np_random)
        self.simulated = SimulatedRobot(maze, self.config, start_pose=self.start_pose, rng=self.np_random)
        self.walls, self.laser = self.simulated.walls, self.simulated.laser
        self._in_sight = WallsInSight(maze, self.walls.surfaces, self.config.laser.max_range)
        self._samples, self._sample_counts = _wall_samples(self.walls.surfaces)
        self._sample_starts = np.cumsum(self._sample_counts) - self._sample_counts
        self.seen = np.zeros(len(self._samples), dtype=bool)
        self._seen_count = 0
        self.visited = np.zeros((maze.rows, maze.cols), dtype=bool)
        self.visited[maze.cell_of(*self.start_pose[:2])] = True
        self._visited_count = 1
        pose = self.simulated.pose
        self._see(pose)
        return self._observation(), self._info(pose, collision=False)

    def step(self, action):
        self.simulated.set_wheel_speeds(*self._command(action))
        collision = self.simulated.advance(self.physics_steps / self.config.logger.physics_rate)
        self.time = self.simulated.time
        distance, turn = self.simulated.read_odometry()
        pose = self.simulated.pose
        cell = self.simulated.maze.cell_of(pose[0], pose[1])  # the episode's maze
        new_cell = not self.visited[cell]
        self.visited[cell] = True
        self._visited_count += new_cell
        newly_seen = self._see(pose)
        reward = (
            self.wall_reward * newly_seen * WALL_SAMPLE_SPACING
            + self.cell_reward * new_cell
            - self.collision_penalty * collision
        )
        terminated = self._visited_count == self.visited.size
        truncated = self.max_steps is not None and self.steps >= self.max_steps
        if self.render_mode == "human":
            self.render()
        return self._observation(distance, turn), float(reward), terminated, truncated, self._info(pose, collision)

    @property
    def world(self):
        """The simulated robot's pymunk world (its ``pose`` is the truth)."""
        return self.simulated.world

    def _see(self, pose: np.ndarray) -> int:
        """Scan from the robot's true ``pose`` (into ``last_scan``) and mark the wall samples its
        noise-free beams land on (on the wall face a beam meets, the sample nearest to where it
        lands, always within ``WALL_SAMPLE_SPACING``); return how many are new."""
        sensor = pose[:2] if not any(self.laser.mount) else transform_points(pose, self.laser.mount)
        sensor_x, sensor_y = float(sensor[0]), float(sensor[1])
        # The laser's own ray cast (as ``true_ranges``), with the wall each beam lands on.
        in_sight = self._in_sight.walls(sensor_x, sensor_y)
        ranges, walls, fractions = self.laser.caster.hits(sensor_x, sensor_y, float(pose[2]), in_sight)
        self.last_scan = self.simulated.read_scan(ranges).astype(np.float32)
        hit = walls >= 0
        walls, counts = walls[hit], self._sample_counts[walls[hit]]
        along = np.minimum((fractions[hit] * counts).astype(np.int64), counts - 1)
        self.seen[self._sample_starts[walls] + along] = True
        before, self._seen_count = self._seen_count, int(np.count_nonzero(self.seen))
        return self._seen_count - before

    def _info(self, pose: np.ndarray, collision: bool) -> dict:
        return {
            "pose": pose,
            "coverage": self._seen_count / len(self.seen),
            "visited": self._visited_count / self.visited.size,
            "collision": bool(collision),
            "time": self.time,
        }

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


def check_maze_settings(rows, cols, maze, loop_fraction, rewards: dict[str, float]) -> None:
    """The env's settings of its mazes and rewards, checked: a ``ValueError`` naming the one out of
    its range (a NaN reward would make every reward NaN; a huge maze would take minutes and
    gigabytes per reset)."""
    _check_maze_size(rows, cols, "rows", "cols")
    _check_loop_fraction(loop_fraction, "loop_fraction")
    _check_maze_choice(maze, "maze")
    for name, value in rewards.items():
        if not (isinstance(value, Real) and math.isfinite(value)):
            raise ValueError(f"{name} must be a finite number, got {value!r}")


def episode_options(options: dict | None, default: Maze | str | None, rows: int, cols: int, loop_fraction: float):
    """``reset``'s ``options`` checked and completed, before the env changes anything: ``maze`` (a
    ``Maze``, a maze file read here, or "random"), ``rows``, ``cols`` and ``loop_fraction`` (of a
    random maze; the env's unless given), and ``start_cell`` (row, col) and ``start_heading`` (rad)
    if given. A ``ValueError`` naming the option and its valid range otherwise."""
    options = dict(options or {})
    unknown = [key for key in options if key not in RESET_OPTIONS]
    if unknown:
        raise ValueError(
            f"unknown reset option{'s' if len(unknown) > 1 else ''} {', '.join(repr(key) for key in unknown)}: "
            f"mazeslam/Maze-v0 takes {', '.join(RESET_OPTIONS)}"
        )
    checked: dict = {
        "rows": options.get("rows", rows),
        "cols": options.get("cols", cols),
        "loop_fraction": options.get("loop_fraction", loop_fraction),
    }
    choice = _check_maze_choice(options.get("maze", default), "options['maze']" if "maze" in options else "maze")
    if choice is None or str(choice) == "random":
        _check_maze_size(checked["rows"], checked["cols"], "options['rows']", "options['cols']")
        _check_loop_fraction(checked["loop_fraction"], "options['loop_fraction']")
        checked["maze"] = "random"
        maze_rows, maze_cols = checked["rows"], checked["cols"]
    else:
        maze = choice if isinstance(choice, Maze) else load_maze(choice)
        checked["maze"] = maze
        maze_rows, maze_cols = maze.rows, maze.cols
    if "start_cell" in options:
        checked["start_cell"] = _check_start_cell(options["start_cell"], maze_rows, maze_cols)
    if "start_heading" in options:
        heading = options["start_heading"]
        if isinstance(heading, bool) or not (isinstance(heading, Real) and math.isfinite(heading)):
            raise ValueError(f"options['start_heading'] must be a finite number of radians, got {heading!r}")
        checked["start_heading"] = float(heading)
    return checked


def _check_maze_size(rows, cols, row_name: str, col_name: str) -> None:
    for name, value in ((row_name, rows), (col_name, cols)):
        if isinstance(value, bool) or not isinstance(value, Integral) or value < 1:
            raise ValueError(f"{name} must be a whole number of cells, at least 1, got {value!r}")
    too_big = maze_problem(int(rows), int(cols))
    if too_big:
        raise ValueError(f"{row_name} x {col_name}: {too_big}")


def _check_loop_fraction(value, name: str) -> None:
    if isinstance(value, bool) or not (isinstance(value, Real) and 0 <= float(value) <= 1):
        raise ValueError(f"{name} must be a number in [0, 1], got {value!r}")


def _check_maze_choice(choice, name: str):
    """``choice`` if it names a maze (a ``Maze`` of at most ``MAX_MAZE_CELLS`` cells, a file,
    "random" or None); a ``ValueError`` naming ``name`` otherwise."""
    if isinstance(choice, Maze):
        too_big = maze_problem(choice.rows, choice.cols)
        if too_big:
            raise ValueError(f"{name}: {too_big}")
    elif choice is not None and not isinstance(choice, (str, os.PathLike)):
        raise ValueError(f"{name} must be a Maze, a maze file or 'random', got {type(choice).__name__}")
    return choice


def _check_start_cell(value, rows: int, cols: int) -> tuple[int, int]:
    """``options["start_cell"]`` as (row, col), a cell of a ``rows`` x ``cols`` maze."""
    valid = (
        isinstance(value, (tuple, list, np.ndarray))
        and len(value) == 2
        and all(isinstance(v, Integral) and not isinstance(v, bool) for v in value)
        and 0 <= value[0] < rows
        and 0 <= value[1] < cols
    )
    if not valid:
        shown = value.tolist() if isinstance(value, np.ndarray) else value
        raise ValueError(
            f"options['start_cell'] must be (row, col) of a cell of the {rows} x {cols} maze, "
            f"0 <= row < {rows} and 0 <= col < {cols}, got {shown!r}"
        )
    return int(value[0]), int(value[1])


def choose_maze(
    options: dict,
    default: Maze | str | None,
    rows: int,
    cols: int,
    loop_fraction: float,
    params: MazeParams,
    rng: np.random.Generator,
) -> Maze:
    """The maze of a new episode: ``options["maze"]`` or ``default`` (a ``Maze``, a maze file, or
    None / "random": a random maze of ``options`` or the given rows, cols and loop fraction, with
    ``params``' cell size and wall thickness, drawn from ``rng``)."""
    choice = options.get("maze", default)
    if isinstance(choice, Maze):
        return choice
    if choice is not None and str(choice) != "random":
        return load_maze(choice)
    return generate_maze(
        options.get("rows", rows),
        options.get("cols", cols),
        rng,
        params.cell_size,
        params.wall_thickness,
        options.get("loop_fraction", loop_fraction),
    )


def draw_start_pose(maze: Maze, options: dict, rng: np.random.Generator) -> np.ndarray:
    """The start pose (x m, y m, theta rad): the centre of ``options["start_cell"]`` or of a random
    cell, facing ``options["start_heading"]`` or a random heading, drawn from ``rng``."""
    start_cell = (int(rng.integers(maze.rows)), int(rng.integers(maze.cols)))  # drawn even if given
    if "start_cell" in options:
        start_cell = _check_start_cell(options["start_cell"], maze.rows, maze.cols)
    heading = float(options.get("start_heading", rng.uniform(-math.pi, math.pi)))
    return np.array([*maze.cell_center(*start_cell), heading])


def _wall_samples(surfaces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Points about every ``WALL_SAMPLE_SPACING`` metres along each wall surface (W, 4): (S, 2)
    the samples, surface after surface, each at the centre of an equal share of its surface, and
    (W,) how many each surface has."""
    counts = np.maximum(1, np.rint(np.hypot(*(surfaces[:, 2:] - surfaces[:, :2]).T) / WALL_SAMPLE_SPACING))
    counts = counts.astype(np.int64)
    surface = np.repeat(np.arange(len(surfaces)), counts)
    t = (np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts) + 0.5) / counts[surface]
    start, end = surfaces[surface, :2], surfaces[surface, 2:]
    return start + t[:, None] * (end - start), counts
