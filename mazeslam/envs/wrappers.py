"""Wrappers for ``mazeslam/Maze-v0``: record episodes as course logs, of the single env
(``RecordCourseLog``) or of every env of its vector env (``RecordVectorCourseLogs``); FastSLAM
online: ``mazeslam.envs.online_slam``."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import gymnasium as gym
import numpy as np

from mazeslam.core.config import to_mapping
from mazeslam.data import sidecars
from mazeslam.data.log import LogWriter

if TYPE_CHECKING:
    from mazeslam.envs.vector_env import MazeVectorEnv


class EpisodeLog:
    """One episode's course log: each step an odometry record followed by a scan record with the
    same timestamp, flushed record by record; ``finish`` closes it and writes the truth and map
    sidecars."""

    def __init__(self, path: Path, beams: int):
        self.path = path
        self._writer = LogWriter(path, beams)
        self._times: list[float] = []
        self._poses: list[np.ndarray] = []

    def write(self, t: float, odometry, scan, pose) -> None:
        """One step: ``t`` seconds, odometry (distance m, turn rad), scan (N,) m, true pose (3,)."""
        self._writer.write_odometry(t, float(odometry[0]), float(odometry[1]))
        self._writer.write_scan(t, np.asarray(scan, dtype=float))
        self._times += [t, t]
        self._poses += [pose, pose]

    def finish(self, episode) -> None:
        """Close the log and write its sidecars; ``episode`` is the env (a ``MazeEnv`` or a
        ``SubEnv``) whose maze, walls, start pose and config the episode had."""
        self._writer.close()
        sidecars.write_truth(sidecars.truth_path(self.path), np.array(self._times), np.array(self._poses))
        maze = episode.maze
        sidecars.write_map(
            sidecars.map_path(self.path),
            episode.walls.surfaces,
            episode.walls.corners,
            episode.config.laser.sensor_mapping(),
            corner_convex=episode.walls.corner_convex.tolist(),
            start_pose=episode.start_pose.tolist(),
            maze={
                "rows": maze.rows,
                "cols": maze.cols,
                "cell_size": maze.cell_size,
                "wall_thickness": maze.wall_thickness,
                "text": maze.to_text(),
            },
            parameters=to_mapping(episode.config),
            source="mazeslam/Maze-v0 episode",
        )


class RecordCourseLog(gym.Wrapper):
    """Writes every episode as a course log with truth and map sidecars, so any agent's run can be
    mapped (``mazeslam slam``). Each step becomes an odometry record followed by a scan record
    with the same timestamp; the log is flushed record by record, the sidecars are written when
    the episode ends (or at the next reset, or on close).

    ``path`` may hold ``{episode}``, replaced by the episode number (0, 1, ...).
    """

    def __init__(self, env: gym.Env, path: str | Path):
        super().__init__(env)
        self.path_template = str(path)
        self.episode = -1
        self._log: EpisodeLog | None = None
        self.log_paths: list[Path] = []

    def reset(self, **kwargs):
        self._finish()
        observation, info = self.env.reset(**kwargs)
        self.episode += 1
        self._log = EpisodeLog(
            Path(self.path_template.format(episode=self.episode)), self.env.unwrapped.config.laser.beams
        )
        self._log.write(0.0, np.zeros(2), observation["scan"], info["pose"])
        self.log_paths.append(self._log.path)
        return observation, info

    def step(self, action):
        observation, reward, terminated, truncated, info = self.env.step(action)
        self._log.write(info["time"], observation["odometry"], observation["scan"], info["pose"])
        if terminated or truncated:
            self._finish()
        return observation, reward, terminated, truncated, info

    def _finish(self) -> None:
        if self._log is not None:
            self._log.finish(self.env.unwrapped)
            self._log = None

    def close(self):
        self._finish()
        super().close()


class RecordVectorCourseLogs(gym.vector.VectorWrapper):
    """``RecordCourseLog`` for each env of a ``MazeVectorEnv``: every episode of env i becomes a
    course log with sidecars. ``path`` may hold ``{env}`` and ``{episode}`` (that env's episode
    number, 0, 1, ...). Follows the vector env's next-step autoreset: a step after an episode's
    end starts the env's next log."""

    def __init__(self, env: gym.vector.VectorEnv, path: str | Path):
        super().__init__(env)
        self.path_template = str(path)
        self.episodes = np.full(self.num_envs, -1)
        self._logs: list[EpisodeLog | None] = [None] * self.num_envs
        self._ended = np.zeros(self.num_envs, dtype=bool)
        self.log_paths: list[Path] = []

    def reset(self, *, seed=None, options=None):
        observation, info = self.env.reset(seed=seed, options=options)
        for env in np.flatnonzero(info["_pose"]):
            self._start(env, observation, info)
        self._ended[info["_pose"]] = False
        return observation, info

    def step(self, actions):
        observation, reward, terminated, truncated, info = self.env.step(actions)
        for env in range(self.num_envs):
            if self._ended[env]:
                self._start(env, observation, info)
            else:
                episode_log = self._logs[env]
                if episode_log is None:
                    raise RuntimeError(f"env {env} has no episode log: reset() it first")
                episode_log.write(
                    info["time"][env], observation["odometry"][env], observation["scan"][env], info["pose"][env]
                )
        self._ended = terminated | truncated
        for env in np.flatnonzero(self._ended):
            self._finish(env)
        return observation, reward, terminated, truncated, info

    def _start(self, env: int, observation: dict, info: dict) -> None:
        self._finish(env)
        self.episodes[env] += 1
        path = Path(self.path_template.format(env=env, episode=self.episodes[env]))
        episode_log = EpisodeLog(path, self._maze_envs().config.laser.beams)
        self._logs[env] = episode_log
        episode_log.write(0.0, np.zeros(2), observation["scan"][env], info["pose"][env])
        self.log_paths.append(path)

    def _finish(self, env: int) -> None:
        episode_log = self._logs[env]
        if episode_log is not None:
            episode_log.finish(self._maze_envs().sub_env(env))
            self._logs[env] = None

    def _maze_envs(self) -> MazeVectorEnv:
        from mazeslam.envs.vector_env import maze_vector_env  # the simulator, loaded when used

        return maze_vector_env(self.env)

    def close(self, **kwargs):
        for env in range(self.num_envs):
            self._finish(env)
        super().close(**kwargs)
