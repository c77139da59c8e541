"""FastSLAM online: a wrapper for ``mazeslam/Maze-v0`` that maps the episode as it happens.

It lives outside ``mazeslam.envs`` so that the simulator does not depend on the filters.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np

from mazeslam.filters.corners import CornerExtractor, CornerParams
from mazeslam.filters.fastslam import FastSLAM, FastSLAMParams


class OnlineFastSLAM(gym.Wrapper):
    """Runs FastSLAM on the episode as it happens and puts its estimate in ``info["slam"]``:
    ``pose`` (3,), ``pose_covariance`` (3, 3), ``landmarks`` (L, 2), ``particles`` (P, 3) poses,
    ``effective_sample_size``.
    The filter starts at the true start pose (the world frame) and sees only the observations."""

    def __init__(self, env: gym.Env, params: FastSLAMParams | None = None, corners: CornerParams | None = None):
        super().__init__(env)
        self.params = params or FastSLAMParams()
        self.corner_params = corners or CornerParams()

    def reset(self, **kwargs):
        observation, info = self.env.reset(**kwargs)
        base = self.env.unwrapped
        self.slam = FastSLAM(self.params, base.start_pose)
        self.extractor = CornerExtractor(base.config.laser.geometry, base.config.laser.beams, self.corner_params)
        self._update(observation["scan"])
        info["slam"] = self._estimate()
        return observation, info

    def step(self, action):
        observation, reward, terminated, truncated, info = self.env.step(action)
        distance, turn = (float(v) for v in observation["odometry"])
        self.slam.predict(distance, turn)
        self._update(observation["scan"])
        info["slam"] = self._estimate()
        return observation, reward, terminated, truncated, info

    def _update(self, scan) -> None:
        features = self.extractor.extract(np.asarray(scan, dtype=float))
        self.last_report = self.slam.update(features.observation_array(), features.observation_covariances())

    def _estimate(self) -> dict:
        return {"pose": self.slam.mean_pose(), "pose_covariance": self.slam.pose_covariance(),
                "landmarks": self.slam.landmarks()[0], "particles": self.slam.poses.copy(),
                "effective_sample_size": self.last_report.effective_sample_size}

    def render(self):
        base = self.env.unwrapped
        if base.render_mode != "rgb_array":
            return self.env.render()
        from mazeslam.envs.rendering import draw_maze_env

        return draw_maze_env(base, {"particles": self.slam.poses, "landmarks": self.slam.landmarks()[0]})
