"""Wrappers for ``mazeslam/Maze-v0``: record an episode as a course log (FastSLAM online:
``mazeslam.online_slam``)."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np

from mazeslam import sidecars
from mazeslam.config import to_mapping
from mazeslam.log import LogWriter


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
        self._writer = None
        self.log_paths: list[Path] = []

    def reset(self, **kwargs):
        self._finish()
        observation, info = self.env.reset(**kwargs)
        self.episode += 1
        path = Path(self.path_template.format(episode=self.episode))
        base = self.env.unwrapped
        self._writer = LogWriter(path, base.config.laser.beams)
        self._times, self._poses = [], []
        self._write(0.0, np.zeros(2), observation["scan"], info["pose"])
        self.log_paths.append(path)
        return observation, info

    def step(self, action):
        observation, reward, terminated, truncated, info = self.env.step(action)
        self._write(info["time"], observation["odometry"], observation["scan"], info["pose"])
        if terminated or truncated:
            self._finish()
        return observation, reward, terminated, truncated, info

    def _write(self, t: float, odometry, scan, pose) -> None:
        self._writer.write_odometry(t, float(odometry[0]), float(odometry[1]))
        self._writer.write_scan(t, np.asarray(scan, dtype=float))
        self._times += [t, t]
        self._poses += [pose, pose]

    def _finish(self) -> None:
        """Close the episode's log and write its sidecars."""
        if self._writer is None:
            return
        self._writer.close()
        self._writer = None
        base = self.env.unwrapped
        path = self.log_paths[-1]
        sidecars.write_truth(sidecars.truth_path(path), np.array(self._times), np.array(self._poses))
        sidecars.write_map(sidecars.map_path(path), base.walls.surfaces, base.walls.corners, base.config.laser.sensor_mapping(),
                           corner_convex=base.walls.corner_convex.tolist(), start_pose=base.start_pose.tolist(),
                           maze={"rows": base.maze.rows, "cols": base.maze.cols, "cell_size": base.maze.cell_size,
                                 "wall_thickness": base.maze.wall_thickness, "text": base.maze.to_text()},
                           parameters=to_mapping(base.config), source="mazeslam/Maze-v0 episode")

    def close(self):
        self._finish()
        super().close()
