"""Wrappers for ``mazeslam/Maze-v0``: record episodes as course logs, of the single env
(``RecordCourseLog``) or of every env of its vector env (``RecordVectorCourseLogs``); FastSLAM
online: ``mazeslam.envs.online_slam``."""

from __future__ import annotations

import string
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
    """One episode's course log with its sidecars, written as the episode goes, so that a script
    that dies loses nothing recorded: the map sidecar when the episode starts (its maze, walls,
    start pose and config are known then), then each step an odometry record followed by a scan
    record with the same timestamp, and their true poses in the truth sidecar, every line flushed.
    ``finish`` closes the files.

    ``episode`` is the env (a ``MazeEnv`` or a ``SubEnv``) just reset."""

    def __init__(self, path: Path, beams: int, episode):
        self.path = path
        _write_map(sidecars.map_path(path), episode)
        self._writer = LogWriter(path, beams)
        self._truth = sidecars.TruthWriter(sidecars.truth_path(path))

    def write(self, t: float, odometry, scan, pose) -> None:
        """One step: ``t`` seconds, odometry (distance m, turn rad), scan (N,) m, true pose (3,)."""
        self._writer.write_odometry(t, float(odometry[0]), float(odometry[1]))
        self._writer.write_scan(t, np.asarray(scan, dtype=float))
        self._truth.write(t, pose)
        self._truth.write(t, pose)

    def finish(self) -> None:
        """Close the log and its truth sidecar."""
        self._writer.close()
        self._truth.close()


def _write_map(path: Path, episode) -> None:
    """The map sidecar of ``episode`` (a ``MazeEnv`` or a ``SubEnv`` just reset)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    maze = episode.maze
    sidecars.write_map(
        path,
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


def episode_path(template: str, episode: int, env: int | None = None) -> Path:
    """The log of episode ``episode`` (of env ``env`` of a vector) from a path ``template``:
    ``{episode}`` and ``{env}`` replaced by the numbers. Without ``{episode}`` in the template,
    episode 0 is written to it and episode n >= 1 beside it as ``<stem>-<n><suffix>``; without
    ``{env}``, a vector's env k adds ``-env<k>`` to the stem: no episode overwrites another."""
    numbers = {"episode": episode} if env is None else {"episode": episode, "env": env}
    path = Path(template.format(**numbers))
    fields = _fields(template)
    suffix = ""
    if env is not None and "env" not in fields:
        suffix += f"-env{env}"
    if episode and "episode" not in fields:
        suffix += f"-{episode}"
    return path.with_name(path.stem + suffix + path.suffix) if suffix else path


def _fields(template: str) -> set[str]:
    """The names in braces in ``template`` (``{episode:03d}``: ``episode``)."""
    return {name for _, name, _, _ in string.Formatter().parse(template) if name is not None}


def _check_template(path: str | Path, *names: str) -> str:
    """``path`` as a template: a ``ValueError`` naming it unless it formats with ``names`` alone."""
    template = str(path)
    try:
        template.format(**dict.fromkeys(names, 0))
    except (KeyError, IndexError, ValueError) as error:
        allowed = " and ".join("{" + name + "}" for name in names)
        raise ValueError(
            f"log path {template!r}: only {allowed} may stand in braces ({type(error).__name__}: {error}); "
            f"write a brace as {{{{ or }}}}"
        ) from error
    return template


class RecordCourseLog(gym.Wrapper):
    """Writes every episode as a course log with truth and map sidecars, so any agent's run can be
    mapped (``mazeslam slam``). Each step becomes an odometry record followed by a scan record
    with the same timestamp, its true pose a line of the truth sidecar; the map sidecar is written
    when the episode starts and every line is flushed, so a script that dies, or never calls
    ``close()``, keeps every episode recorded so far (``EpisodeLog``).

    ``path`` may hold ``{episode}``, replaced by the episode number (0, 1, ...); without it, the
    first episode is written to ``path`` and episode n >= 1 to ``<stem>-<n><suffix>`` beside it
    (``runs/agent.log``, ``runs/agent-1.log``, ...), never over another (``episode_path``).
    ``log_paths`` lists the logs written.
    """

    def __init__(self, env: gym.Env, path: str | Path):
        super().__init__(env)
        self.path_template = _check_template(path, "episode")
        self.episode = -1
        self._log: EpisodeLog | None = None
        self.log_paths: list[Path] = []

    def reset(self, **kwargs):
        self._finish()
        observation, info = self.env.reset(**kwargs)
        self.episode += 1
        base = self.env.unwrapped
        self._log = EpisodeLog(episode_path(self.path_template, self.episode), base.config.laser.beams, base)
        self._log.write(0.0, np.zeros(2), observation["scan"], info["pose"])
        self.log_paths.append(self._log.path)
        return observation, info

    def step(self, action):
        if self._log is None:
            raise RuntimeError("RecordCourseLog: no episode is being recorded: call reset() before step()")
        observation, reward, terminated, truncated, info = self.env.step(action)
        self._log.write(info["time"], observation["odometry"], observation["scan"], info["pose"])
        if terminated or truncated:
            self._finish()
        return observation, reward, terminated, truncated, info

    def _finish(self) -> None:
        if self._log is not None:
            self._log.finish()
            self._log = None

    def close(self):
        self._finish()
        super().close()


class RecordVectorCourseLogs(gym.vector.VectorWrapper):
    """``RecordCourseLog`` for each env of a ``MazeVectorEnv``: every episode of env i becomes a
    course log with sidecars, written as it goes. ``path`` may hold ``{env}`` and ``{episode}``
    (that env's episode number, 0, 1, ...); without them, ``-env<i>`` and ``-<n>`` (from episode 1
    on) are added to its stem (``episode_path``). Follows the vector env's next-step autoreset: a
    step after an episode's end starts the env's next log."""

    def __init__(self, env: gym.vector.VectorEnv, path: str | Path):
        super().__init__(env)
        self.path_template = _check_template(path, "env", "episode")
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
        path = episode_path(self.path_template, int(self.episodes[env]), env)
        maze_envs = self._maze_envs()
        episode_log = EpisodeLog(path, maze_envs.config.laser.beams, maze_envs.sub_env(env))
        self._logs[env] = episode_log
        episode_log.write(0.0, np.zeros(2), observation["scan"][env], info["pose"][env])
        self.log_paths.append(path)

    def _finish(self, env: int) -> None:
        episode_log = self._logs[env]
        if episode_log is not None:
            episode_log.finish()
            self._logs[env] = None

    def _maze_envs(self) -> MazeVectorEnv:
        from mazeslam.envs.vector_env import maze_vector_env  # the simulator, loaded when used

        return maze_vector_env(self.env)

    def close(self, **kwargs):
        for env in range(self.num_envs):
            self._finish(env)
        super().close(**kwargs)
