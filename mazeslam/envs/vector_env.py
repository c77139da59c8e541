"""``MazeVectorEnv``: many maze robots stepped together, the vector entry point of ``mazeslam/Maze-v0``.

    envs = gym.make_vec("mazeslam/Maze-v0", num_envs=64, vectorization_mode="vector_entry_point")

Its physics is batched numpy (``mazeslam.sim.batched``), not pymunk: every robot's
differential-drive kinematics is integrated at once, the discs are pushed out of the walls they
touch, and one ray cast serves every robot's beams. So an env's episode here differs from the
pymunk-backed ``MazeEnv``'s with the same seed after the start (same maze and start pose, as both
draw them alike), but it is the same whether the env runs alone (``num_envs=1``) or in a vector
of any size: each env draws from its own generator, in an order that depends only on its own
history.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from mazeslam.core.geometry import wrap_angle
from mazeslam.envs.drive_env import DriveEnv, _shown, checked_actions
from mazeslam.envs.maze_env import (
    WALL_SAMPLE_SPACING,
    check_maze_settings,
    choose_maze,
    draw_start_pose,
    episode_options,
)
from mazeslam.sim.batched import MazeGrids, slide
from mazeslam.sim.maze import Maze
from mazeslam.sim.simulator import SimulationConfig
from mazeslam.sim.walls import WallGeometry, wall_geometry

#: Steps of random draws an env takes from its generator at a time (``MazeVectorEnv._draw``).
DRAW_AHEAD = 32


class MazeVectorEnv(VectorEnv):
    """``num_envs`` copies of ``mazeslam/Maze-v0`` stepped together (see ``MazeEnv`` for the
    actions, observations, rewards, episode end and info, and ``DriveEnv`` for the spaces).

    Spaces are the single env's batched: ``action_space`` ``Box(-1, 1, (num_envs, 2))``,
    ``observation_space`` ``Dict(scan: (num_envs, N), odometry: (num_envs, 2))``; rewards,
    terminations and truncations are (num_envs,) arrays; ``info`` holds each single-env key as a
    (num_envs, ...) array with its ``_key`` mask, as ``SyncVectorEnv`` gives them.

    Autoreset: ``AutoresetMode.NEXT_STEP`` (``metadata["autoreset_mode"]``): the step after an
    env's episode ends resets it, ignoring its action, and returns its first observation with
    reward 0. ``reset(seed=s)`` seeds env i with ``s + i`` (a list: one seed per env);
    ``options`` as the single env's, for every env reset, plus ``reset_mask`` (num_envs,) bool to
    reset only some. All mazes of a vector share their rows, cols, cell size and wall thickness;
    changing them takes a reset of every env.

    Physics: per physics step (``config.logger.physics_rate``) the wheels' commanded travel plus
    slip (``config.odometry``) moves each robot, which is then pushed out of any wall it overlaps
    (``collision``); the odometry counts the commanded whole encoder steps, as ``WheelEncoders``.

    ``render()`` (``render_mode="rgb_array"``) gives one image of the envs in ``render_envs``,
    tiled left to right, top to bottom.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 10, "autoreset_mode": AutoresetMode.NEXT_STEP}

    def __init__(
        self,
        num_envs: int = 1,
        render_mode: str | None = None,
        config: SimulationConfig | None = None,
        rows: int = 4,
        cols: int = 4,
        maze: Maze | str | None = None,
        loop_fraction: float = 0.0,
        max_steps: int = 3000,
        control_period: float = 0.1,
        action_type: str = "velocity",
        wall_reward: float = 10.0,
        cell_reward: float = 1.0,
        collision_penalty: float = 0.5,
        render_envs: tuple[int, ...] = (0,),
    ):
        if num_envs < 1:
            raise ValueError(f"num_envs must be >= 1, got {num_envs}")
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode must be one of {self.metadata['render_modes']} or None, got {render_mode!r}")
        single = DriveEnv(config, max_steps, control_period, action_type)  # checks them; the single spaces
        check_maze_settings(
            rows,
            cols,
            maze,
            loop_fraction,
            {"wall_reward": wall_reward, "cell_reward": cell_reward, "collision_penalty": collision_penalty},
        )
        self.num_envs, self.render_mode, self.render_envs = num_envs, render_mode, tuple(render_envs)
        self.config, self.max_steps, self.action_type = single.config, max_steps, action_type
        self.top_turn_rate = single.top_turn_rate
        self.single_observation_space, self.single_action_space = single.observation_space, single.action_space
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = batch_space(self.single_action_space, num_envs)
        self.rows, self.cols, self.maze_option, self.loop_fraction = rows, cols, maze, loop_fraction
        self.wall_reward, self.cell_reward, self.collision_penalty = wall_reward, cell_reward, collision_penalty
        self.physics_steps = max(1, round(control_period * self.config.logger.physics_rate))
        laser, robot = self.config.laser, self.config.robot
        self.bearings = laser.geometry.bearings(laser.beams)  # (N,) robot frame, rad
        self.metres_per_step = 2 * np.pi * robot.wheel_radius / robot.encoder_steps_per_revolution
        self.generators: list[np.random.Generator | None] = [None] * num_envs
        self.mazes: list[Maze | None] = [None] * num_envs
        self.grids: MazeGrids | None = None
        self.poses = np.zeros((num_envs, 3))  # true poses (x m, y m, theta rad)
        self.start_poses = np.zeros((num_envs, 3))
        self.steps = np.zeros(num_envs, dtype=np.int64)  # steps into each episode
        self.time = np.zeros(num_envs)  # simulated seconds into each episode
        self.last_scan = np.zeros((num_envs, laser.beams), dtype=np.float32)
        self._commanded = np.zeros((num_envs, 2))  # commanded wheel travel since the start, m
        self._reported = np.zeros((num_envs, 2), dtype=np.int64)  # encoder steps already reported
        self._collision = np.zeros(num_envs, dtype=bool)
        self._autoreset = np.zeros(num_envs, dtype=bool)
        # Random draws made ahead (``_draw``): per env, DRAW_AHEAD steps of normals (slip, noise)
        # and of dropout uniforms, and how many steps of them are used.
        self._normals = np.zeros((num_envs, DRAW_AHEAD, 2 * self.physics_steps + laser.beams), dtype=np.float32)
        self._uniforms = np.ones((num_envs, DRAW_AHEAD, laser.beams), dtype=np.float32) if laser.dropout else None
        self._no_dropouts = np.ones((num_envs, laser.beams))
        self._noise = np.empty((num_envs, laser.beams), dtype=np.float32)  # a scan's noise, m
        self._noisy = np.empty((num_envs, laser.beams))  # a scan's noisy ranges, m
        self._drawn = np.full(num_envs, DRAW_AHEAD)

    # -- episode ------------------------------------------------------------------------------
    def reset(self, *, seed: int | list[int | None] | None = None, options: dict | None = None):
        options = dict(options or {})
        mask = options.pop("reset_mask", None)
        envs = np.arange(self.num_envs) if mask is None else np.flatnonzero(_check_mask(mask, self.num_envs))
        seeds = _env_seeds(seed, self.num_envs)
        # Every option checked (a maze file read once) before any env changes.
        options = episode_options(options, self.maze_option, self.rows, self.cols, self.loop_fraction)
        if len(envs) < self.num_envs:
            if self.grids is None:
                raise ValueError("the first reset() must reset every env: options['reset_mask'] must be all True")
            if not self._fits(options):
                raise ValueError("a maze of another shape needs a reset of every env (no options['reset_mask'])")
        self._reset_envs(envs, [seeds[e] for e in envs], options)
        _, scan_noise, dropouts = self._draw(envs)
        self._observe(envs, scan_noise, dropouts)
        return self._observation(np.zeros((self.num_envs, 2))), self._infos(envs)

    def step(self, actions):
        if self.grids is None:
            raise RuntimeError("MazeVectorEnv: call reset() before step()")
        actions = checked_actions(actions, self.action_space, "actions")
        actions = np.minimum(np.maximum(actions, -1.0), 1.0)
        resetting = self._autoreset.copy()
        if resetting.any():
            self._reset_envs(np.flatnonzero(resetting), [None] * int(resetting.sum()), {})
        moving = ~resetting
        everyone = np.arange(self.num_envs)
        slip, scan_noise, dropouts = self._draw(everyone)
        self._collision = self._drive(self._wheel_speeds(actions) * moving[:, None], slip)
        self.steps += moving
        self.time += moving * self.physics_steps / self.config.logger.physics_rate
        odometry = self._read_odometry()
        newly_seen, new_cell = self._observe(everyone, scan_noise, dropouts)
        rewards = (
            self.wall_reward * newly_seen * WALL_SAMPLE_SPACING
            + self.cell_reward * new_cell
            - self.collision_penalty * self._collision
        ) * moving
        terminated = (self.visited_counts == self.visited[0].size) & moving
        truncated = (self.steps >= self.max_steps) & moving
        self._autoreset = terminated | truncated
        return self._observation(odometry), rewards, terminated, truncated, self._infos(everyone)

    def _reset_envs(self, envs: np.ndarray, seeds: list[int | None], options: dict) -> None:
        """Draw each env's maze and start pose and clear its episode (no scan yet)."""
        for env, seed in zip(envs, seeds):
            if seed is not None or self.generators[env] is None:
                self.generators[env], _ = seeding.np_random(seed)
                self._drawn[env] = DRAW_AHEAD  # nothing drawn yet from the new generator
            rng = self.generators[env]
            maze = choose_maze(
                options, self.maze_option, self.rows, self.cols, self.loop_fraction, self.config.maze, rng
            )
            self.mazes[env] = maze
            self.start_poses[env] = draw_start_pose(maze, options, rng)
        if len(envs) and (self.grids is None or not all(self.grids.fits(self.mazes[e]) for e in envs)):
            if len(envs) < self.num_envs:
                raise ValueError("a maze of another shape needs a reset of every env")
            self._allocate(self._maze(0))
        grids = self._grids()
        for env in envs:
            grids.set(env, self.mazes[env])
            self.wall_bins[env] = grids.wall_bins(env, WALL_SAMPLE_SPACING)
            self.seen[env] = False
            self._unseen[env] = self.wall_bins[env]
            self.visited[env] = False
        self.wall_counts[envs] = self.wall_bins[envs].sum(axis=1)
        self.seen_counts[envs] = 0
        self.visited_counts[envs] = 0
        self.poses[envs] = self.start_poses[envs]
        self._mark_visited(envs)
        for array in (self.steps, self.time, self._commanded, self._reported, self._collision, self._autoreset):
            array[envs] = 0

    def _fits(self, options: dict) -> bool:
        """Whether the mazes of checked reset ``options`` (``episode_options``) have the grids' shape."""
        grids, maze = self._grids(), options["maze"]
        if isinstance(maze, Maze):
            return grids.fits(maze)
        shape = (2 * options["rows"] + 1, 2 * options["cols"] + 1)
        params = self.config.maze
        return grids.solid.shape[1:] == shape and (params.cell_size, params.wall_thickness) == (
            grids.cell_size,
            grids.thickness,
        )

    def _grids(self) -> MazeGrids:
        """The mazes' grids, made by the first reset (of every env)."""
        if self.grids is None:
            raise RuntimeError("MazeVectorEnv: reset() every env first")
        return self.grids

    def _maze(self, env: int) -> Maze:
        """Env ``env``'s current maze, drawn by its first reset."""
        maze = self.mazes[env]
        if maze is None:
            raise RuntimeError(f"MazeVectorEnv: env {env} has no maze before its first reset()")
        return maze

    def _allocate(self, maze: Maze) -> None:
        """Grids and per-env bookkeeping for mazes shaped like ``maze``."""
        self.grids = MazeGrids.like(maze, self.num_envs)
        bins = self.grids.bin_total(WALL_SAMPLE_SPACING)
        self.wall_bins = np.zeros((self.num_envs, bins), dtype=bool)  # bins on a wall face
        self.seen = np.zeros((self.num_envs, bins), dtype=bool)  # wall bins a beam landed in
        self._unseen = np.zeros((self.num_envs, bins), dtype=bool)  # wall bins no beam landed in yet
        self.wall_counts = np.zeros(self.num_envs, dtype=np.int64)
        self.seen_counts = np.zeros(self.num_envs, dtype=np.int64)
        self.visited = np.zeros((self.num_envs, maze.rows, maze.cols), dtype=bool)
        self.visited_counts = np.zeros(self.num_envs, dtype=np.int64)  # cells visited

    def _draw(self, envs: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The listed envs' random draws for one step (float32), from each env's own generator: standard
        normals for the wheel slip (E', physics steps, 2) and the range noise (E', N), and uniforms
        for the dropouts (E', N) (ones without dropouts: never dropped). Each generator is drawn
        ``DRAW_AHEAD`` steps at a time (uniforms made normals by ``box_muller``, then the dropout
        uniforms), so the draws of an env depend on its own history only."""
        empty = envs[self._drawn[envs] == DRAW_AHEAD]
        if len(empty):
            self._draw_ahead(empty)
        rows = self._drawn[envs]
        self._drawn[envs] += 1
        which: slice | np.ndarray = envs
        if len(envs) == self.num_envs and (rows == rows[0]).all():  # every env at the same row: a view
            which, rows = slice(None), rows[0]
        normals, steps = self._normals[which, rows], self.physics_steps
        uniforms = self._no_dropouts[: len(normals)] if self._uniforms is None else self._uniforms[which, rows]
        return normals[:, : 2 * steps].reshape(-1, steps, 2), normals[:, 2 * steps :], uniforms

    def _draw_ahead(self, envs: np.ndarray) -> None:
        """Refill the listed envs' ``DRAW_AHEAD`` steps of draws, each from its own generator."""
        normals = self._normals.reshape(self.num_envs, -1)  # per env, its uniforms then normals
        for env in envs:
            rng = self.generators[env]
            assert rng is not None  # reset first
            rng.random(dtype=np.float32, out=normals[env])
            if self._uniforms is not None:
                rng.random(dtype=np.float32, out=self._uniforms[env])
        if len(envs) == self.num_envs:  # every env (in order): at once, each row as alone
            box_muller(normals)
        else:
            for env in envs:
                box_muller(normals[env])
        self._drawn[envs] = 0

    # -- physics ------------------------------------------------------------------------------
    def _wheel_speeds(self, actions: np.ndarray) -> np.ndarray:
        """(E, 2) left and right wheel speeds (m/s) for actions (E, 2) in [-1, 1], as ``DriveEnv``."""
        robot = self.config.robot
        if self.action_type == "wheels":
            return actions * robot.max_wheel_speed
        speed = actions[:, 0] * robot.max_wheel_speed
        half_difference = 0.5 * actions[:, 1] * self.top_turn_rate * robot.wheelbase
        wheels = np.empty((len(actions), 2))
        np.subtract(speed, half_difference, out=wheels[:, 0])
        np.add(speed, half_difference, out=wheels[:, 1])
        fastest = np.maximum(np.abs(wheels[:, 0]), np.abs(wheels[:, 1]))[:, None]
        return wheels * np.minimum(1.0, robot.max_wheel_speed / np.maximum(fastest, 1e-12))

    def _drive(self, speeds: np.ndarray, slip: np.ndarray) -> np.ndarray:
        """Drive every robot at wheel ``speeds`` (E, 2) (m/s) for one step of physics steps, with
        ``slip`` (E, steps, 2) standard normals; return (E,) whether each touched a wall.

        Each physics step moves a robot along its midpoint heading by its wheels' mean true
        travel (commanded, scaled, plus slip) and then pushes it out of the walls; the headings of
        all the physics steps are known beforehand (contacts never turn a robot)."""
        robot, odometry = self.config.robot, self.config.odometry
        dt, steps = 1.0 / self.config.logger.physics_rate, slip.shape[1]
        commanded = speeds * dt  # (E, 2) m per physics step
        self._commanded += commanded * steps
        # Physics step by env, env last: (2 wheels, steps, E) m, (steps, E) rad and m.
        scale = 1.0 + np.array([[odometry.left_scale_error], [odometry.right_scale_error]])
        commanded = commanded.T
        travel = (commanded * scale)[:, None] + slip.T * (odometry.slip_std * np.sqrt(np.abs(commanded)))[:, None]
        turn = (travel[1] - travel[0]) / robot.wheelbase
        headings = np.empty((steps + 1, self.num_envs))  # before and after each physics step
        headings[0], headings[1:] = self.poses[:, 2], turn
        np.cumsum(headings, axis=0, out=headings)
        middle = headings[:-1] + 0.5 * turn
        forward = 0.5 * (travel[0] + travel[1])
        moves = np.empty((2, steps, self.num_envs))  # (x, y; steps, E) m
        np.multiply(forward, np.cos(middle), out=moves[0])
        np.multiply(forward, np.sin(middle), out=moves[1])
        start = self.poses[:, :2].T  # (2, E) m
        reach = robot.body_radius + 2 * robot.max_wheel_speed * dt * steps  # with room for slip
        boxes = self._grids().boxes_near(start[0], start[1], reach)  # (4, B, E)
        # Every physics step's position without walls, (2, steps + 1, E), the same sums as the
        # step-by-step loop below; a robot that overlaps no box at any of them never touches a wall.
        path = np.empty((2, steps + 1, self.num_envs))
        path[:, 0] = start
        path[:, 1:] = moves
        np.cumsum(path, axis=1, out=path)
        point = path[:, None, 1:]  # (2, 1, steps, E)
        gap = point - np.minimum(np.maximum(point, boxes[:2, :, None]), boxes[2:, :, None])
        squared = gap[0] * gap[0] + gap[1] * gap[1]  # (B, steps, E)
        overlaps = squared.min(axis=0) < robot.body_radius * robot.body_radius  # (steps, E)
        touching = overlaps.any(axis=0).nonzero()[0]
        position = path[:, -1].copy()
        touched = np.zeros(self.num_envs, dtype=bool)
        if len(touching):  # step by step from each one's first overlap on, pushed out of the walls
            firsts = overlaps[:, touching].argmax(axis=0).tolist()
            starts = path[:, :, touching].T.tolist()  # (E', steps + 1, 2)
            moving = moves[:, :, touching].T.tolist()  # (E', steps, 2)
            near = boxes[:, :, touching].T.tolist()  # (E', B, 4)
            # The boxes within ``reach`` of the wall-free path: being pushed out of walls moves a
            # robot less than its path's length, so it can overlap no other.
            close = (squared[:, :, touching].min(axis=1) < reach * reach).T.tolist()  # (E', B)
            for k, env in enumerate(touching.tolist()):
                first, solid = firsts[k], [box for box, kept in zip(near[k], close[k]) if kept]
                x, y = starts[k][first]
                x, y, touched[env] = slide(x, y, moving[k][first:], robot.body_radius, solid)
                position[0, env], position[1, env] = x, y
        self.poses = np.empty((self.num_envs, 3))
        self.poses[:, :2], self.poses[:, 2] = position.T, wrap_angle(headings[-1])
        return touched

    def _read_odometry(self) -> np.ndarray:
        """(E, 2) odometry since the previous read: distance (m), heading change (rad)."""
        steps = np.floor(self._commanded / self.metres_per_step + 1e-9).astype(np.int64)
        left, right = ((steps - self._reported) * self.metres_per_step).T
        self._reported = steps
        odometry = np.empty((self.num_envs, 2))
        odometry[:, 0], odometry[:, 1] = 0.5 * (left + right), (right - left) / self.config.robot.wheelbase
        return odometry

    # -- sensing ------------------------------------------------------------------------------
    def _observe(self, envs: np.ndarray, noise: np.ndarray, uniforms: np.ndarray):
        """Scan from the listed envs' poses (into ``last_scan``), with their range ``noise`` (E', N)
        (standard normals) and dropout ``uniforms`` (E', N); count the wall bins their noise-free
        beams land on and the cells they stand in; return (E,) newly seen bins and (E,) new cells."""
        laser = self.config.laser
        sensor_x, sensor_y, heading = self.poses[envs].T
        mount_x, mount_y = laser.geometry.mount_x, laser.geometry.mount_y
        if mount_x or mount_y:
            cos_h, sin_h = np.cos(heading), np.sin(heading)
            sensor_x, sensor_y = (
                sensor_x + mount_x * cos_h - mount_y * sin_h,
                sensor_y + mount_x * sin_h + mount_y * cos_h,
            )
        grids = self._grids()
        ranges, edges, along = grids.cast_edges(envs, sensor_x, sensor_y, heading, self.bearings, laser.max_range)
        hit = np.isfinite(ranges)
        noisy = np.multiply(noise, laser.range_noise_std, out=self._noise[: len(envs)])
        noisy = np.add(ranges, noisy, out=self._noisy[: len(envs)])  # inf where no wall: not valid
        valid = noisy <= laser.max_range
        valid &= noisy >= laser.min_range
        if laser.dropout:
            valid &= uniforms >= laser.dropout
        self.last_scan[slice(None) if len(envs) == self.num_envs else envs] = np.where(valid, noisy, 0.0)
        bins = (envs[:, None] * self.seen.shape[1] + grids.edge_bins(edges, along, WALL_SAMPLE_SPACING))[hit]
        new = bins[self._unseen.ravel()[bins]]
        if len(new) > 1:
            new = np.unique(new)
        self.seen.ravel()[new] = True
        self._unseen.ravel()[new] = False
        newly_seen = np.bincount(new // self.seen.shape[1], minlength=self.num_envs)
        self.seen_counts += newly_seen
        return newly_seen, self._mark_visited(envs)

    def _mark_visited(self, envs: np.ndarray) -> np.ndarray:
        """Mark the cells the listed envs' robots stand in; return (E,) whether each was new."""
        rows, cols = self.visited.shape[1:]
        cells = (self.poses[envs, :2] // self._grids().cell_size).astype(np.int64)
        np.maximum(cells, 0, out=cells)
        np.minimum(cells, [cols - 1, rows - 1], out=cells)
        cell = envs * (rows * cols) + cells[:, 1] * cols + cells[:, 0]
        new = np.zeros(self.num_envs, dtype=bool)
        new[envs] = ~self.visited.ravel()[cell]
        self.visited.ravel()[cell] = True
        self.visited_counts += new
        return new

    def _observation(self, odometry: np.ndarray) -> dict:
        return {"scan": self.last_scan.copy(), "odometry": odometry.astype(np.float32)}

    def _infos(self, envs: np.ndarray) -> dict:
        """The single env's info keys as (E, ...) arrays, with ``_key`` masks marking ``envs``."""
        mask = np.zeros(self.num_envs, dtype=bool)
        mask[envs] = True
        values = {
            "pose": self.poses.copy(),
            "coverage": self.seen_counts / self.wall_counts,
            "visited": self.visited_counts / self.visited[0].size,
            "collision": self._collision.copy(),
            "time": self.time.copy(),
        }
        return {**values, **{f"_{key}": mask.copy() for key in values}}

    # -- one env's view, rendering --------------------------------------------------------------
    def sub_env(self, index: int) -> SubEnv:
        """Env ``index``'s episode as a single env shows it (for wrappers and drawing)."""
        seen = self.seen[index] & self.wall_bins[index]
        return SubEnv(
            self._maze(index),
            self.config,
            self.start_poses[index].copy(),
            self.poses[index].copy(),
            self.visited[index].copy(),
            self.last_scan[index].copy(),
            self._grids().bin_points(np.flatnonzero(seen), WALL_SAMPLE_SPACING),
        )

    def render(self):
        if self.render_mode is None:
            return None
        from mazeslam.envs.rendering import draw_maze_env

        images = [draw_maze_env(self.sub_env(index)) for index in self.render_envs]
        columns = int(np.ceil(np.sqrt(len(images))))
        blank = np.full_like(images[0], 255)
        images += [blank] * (-len(images) % columns)
        return np.concatenate(
            [np.concatenate(images[k : k + columns], axis=1) for k in range(0, len(images), columns)], axis=0
        )


@dataclass
class SubEnv:
    """One env of a ``MazeVectorEnv``, with the attributes of a ``MazeEnv`` that the course-log and
    FastSLAM wrappers and ``draw_maze_env`` read.

    Attributes:
        seen_points: (S, 2) centres (m) of the wall bins seen so far.
    """

    maze: Maze
    config: SimulationConfig
    start_pose: np.ndarray
    pose: np.ndarray
    visited: np.ndarray
    last_scan: np.ndarray
    seen_points: np.ndarray

    @cached_property
    def walls(self) -> WallGeometry:
        return wall_geometry(self.maze)

    @property
    def world(self) -> SubEnv:
        """Itself: ``draw_maze_env`` reads the true pose as ``env.world.pose``."""
        return self

    @property
    def _samples(self) -> np.ndarray:  # draw_maze_env draws ``_samples[seen]``
        return self.seen_points

    @property
    def seen(self) -> np.ndarray:
        return np.ones(len(self.seen_points), dtype=bool)


def box_muller(uniforms: np.ndarray) -> None:
    """Turn float32 ``uniforms`` in [0, 1) (..., n), n even, into independent standard normals, in
    place, row by row: a row's first half's radii with its second half's angles (Box-Muller), a few
    vectorised float32 calls, several times faster than numpy's float32 ziggurat sampler element
    for element. Each element's result depends only on its row's values (numpy's float32
    functions give an element the same result at any place in a contiguous row)."""
    half = uniforms.shape[-1] // 2
    radius = np.log1p(-uniforms[..., :half])  # 1 - u in (0, 1]: a finite log
    radius *= -2
    np.sqrt(radius, out=radius)  # at most sqrt(2 * 24 ln 2) = 5.8 for float32 uniforms
    angle = uniforms[..., half:]
    angle *= np.float32(2 * np.pi)
    np.cos(angle, out=uniforms[..., :half])
    np.sin(angle, out=uniforms[..., half:])
    uniforms[..., :half] *= radius
    uniforms[..., half:] *= radius


def _env_seeds(seed: int | list[int | None] | None, count: int) -> list[int | None]:
    """One seed per env as ``SyncVectorEnv`` takes them: None, ``seed + i``, or a list of ``count``
    seeds (each None or a whole number >= 0). A ``ValueError`` naming the seed otherwise, before any
    env changes (a bad seed met while resetting env after env left the earlier ones reset)."""
    if seed is None:
        return [None] * count
    if isinstance(seed, (int, np.integer)) and _is_seed(seed):
        return [int(seed) + index for index in range(count)]
    if not isinstance(seed, (list, tuple, np.ndarray)) or len(seed) != count:
        raise ValueError(
            f"seed must be None, a whole number >= 0 or a list of num_envs={count} seeds, got {_shown(seed)}"
        )
    bad = [value for value in seed if value is not None and not _is_seed(value)]
    if bad:
        raise ValueError(f"each seed of the list must be None or a whole number >= 0, got {_shown(bad[0])}")
    return [None if value is None else int(value) for value in seed]


def _is_seed(value) -> bool:
    """Whether ``value`` is a seed Gymnasium takes: a whole number >= 0 (not a bool)."""
    return bool(isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_)) and value >= 0)


def _check_mask(mask, count: int) -> np.ndarray:
    """``options["reset_mask"]``, checked as ``SyncVectorEnv`` checks it."""
    if not isinstance(mask, np.ndarray) or mask.dtype != np.bool_ or mask.shape != (count,):
        raise ValueError(f"options['reset_mask'] must be a bool numpy array of shape ({count},)")
    if not mask.any():
        raise ValueError("options['reset_mask'] must reset at least one env")
    return mask


def maze_vector_env(env: VectorEnv) -> MazeVectorEnv:
    """The ``MazeVectorEnv`` under ``env`` (its wrappers removed), for the wrappers that need its
    episodes (``sub_env``) and config; a ``TypeError`` if there is none."""
    base = env.unwrapped
    if not isinstance(base, MazeVectorEnv):
        raise TypeError(f"needs a MazeVectorEnv underneath, got {type(base).__name__}")
    return base
