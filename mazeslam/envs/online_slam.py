"""FastSLAM online: wrappers for ``mazeslam/Maze-v0`` (``OnlineFastSLAM``) and its vector env
(``VectorOnlineFastSLAM``) that map each episode as it happens.

They live outside ``mazeslam.envs`` so that the simulator does not depend on the filters.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np

from mazeslam.fastslam.filter import FastSLAM, FastSLAMParams
from mazeslam.features.corners import CornerExtractor, CornerParams


class EpisodeSLAM:
    """FastSLAM over one episode: starts at the true start pose (the world frame) and sees only
    the observations (odometry, scans)."""

    def __init__(self, episode, params: FastSLAMParams, corners: CornerParams):
        laser = episode.config.laser
        self.slam = FastSLAM(params, episode.start_pose)
        self.extractor = CornerExtractor(laser.geometry, laser.beams, corners)

    def update(self, scan, odometry=None) -> None:
        """Predict with ``odometry`` (distance m, turn rad; none at the episode's start), then update
        with the corners of ``scan`` (N,) m."""
        if odometry is not None:
            self.slam.predict(*(float(v) for v in odometry))
        features = self.extractor.extract(np.asarray(scan, dtype=float))
        self.last_report = self.slam.update(features.observation_array(), features.observation_covariances())

    def estimate(self) -> dict:
        """``pose`` (3,), ``pose_covariance`` (3, 3), ``landmarks`` (L, 2), ``particles`` (P, 3)
        poses, ``effective_sample_size``."""
        return {
            "pose": self.slam.mean_pose(),
            "pose_covariance": self.slam.pose_covariance(),
            "landmarks": self.slam.landmarks()[0],
            "particles": self.slam.poses.copy(),
            "effective_sample_size": self.last_report.effective_sample_size,
        }


class OnlineFastSLAM(gym.Wrapper):
    """Runs FastSLAM on the episode as it happens and puts its estimate (``EpisodeSLAM.estimate``)
    in ``info["slam"]``. The filter starts at the true start pose (the world frame) and sees only
    the observations."""

    def __init__(self, env: gym.Env, params: FastSLAMParams | None = None, corners: CornerParams | None = None):
        super().__init__(env)
        self.params = params or FastSLAMParams()
        self.corner_params = corners or CornerParams()

    def reset(self, **kwargs):
        observation, info = self.env.reset(**kwargs)
        self.episode = EpisodeSLAM(self.env.unwrapped, self.params, self.corner_params)
        self.episode.update(observation["scan"])
        info["slam"] = self.episode.estimate()
        return observation, info

    def step(self, action):
        observation, reward, terminated, truncated, info = self.env.step(action)
        self.episode.update(observation["scan"], observation["odometry"])
        info["slam"] = self.episode.estimate()
        return observation, reward, terminated, truncated, info

    @property
    def slam(self) -> FastSLAM:
        return self.episode.slam

    def render(self):
        base = self.env.unwrapped
        if base.render_mode != "rgb_array":
            return self.env.render()
        from mazeslam.envs.rendering import draw_maze_env

        return draw_maze_env(base, {"particles": self.slam.poses, "landmarks": self.slam.landmarks()[0]})


class VectorOnlineFastSLAM(gym.vector.VectorWrapper):
    """``OnlineFastSLAM`` for each env of a ``MazeVectorEnv``: one filter per env, restarted with
    each of its episodes (next-step autoreset: the step after an episode's end starts the next).
    ``info["slam"]`` holds each estimate's key over the envs: ``pose`` (E, 3), ``pose_covariance``
    (E, 3, 3), ``particles`` (E, P, 3), ``effective_sample_size`` (E,), and ``landmarks`` an (E,)
    object array of (L, 2) arrays."""

    def __init__(
        self, env: gym.vector.VectorEnv, params: FastSLAMParams | None = None, corners: CornerParams | None = None
    ):
        super().__init__(env)
        self.params = params or FastSLAMParams()
        self.corner_params = corners or CornerParams()
        self.episodes: list[EpisodeSLAM | None] = [None] * self.num_envs
        self._ended = np.zeros(self.num_envs, dtype=bool)

    def reset(self, *, seed=None, options=None):
        observation, info = self.env.reset(seed=seed, options=options)
        for env in np.flatnonzero(info["_pose"]):
            self._start(env, observation["scan"][env])
        self._ended[info["_pose"]] = False
        info["slam"] = self._estimates()
        return observation, info

    def step(self, actions):
        observation, reward, terminated, truncated, info = self.env.step(actions)
        for env in range(self.num_envs):
            if self._ended[env]:
                self._start(env, observation["scan"][env])
            else:
                self._episode(env).update(observation["scan"][env], observation["odometry"][env])
        self._ended = terminated | truncated
        info["slam"] = self._estimates()
        return observation, reward, terminated, truncated, info

    def _start(self, env: int, scan) -> None:
        from mazeslam.envs.vector_env import maze_vector_env

        episode = EpisodeSLAM(maze_vector_env(self.env).sub_env(env), self.params, self.corner_params)
        self.episodes[env] = episode
        episode.update(scan)

    def _episode(self, env: int) -> EpisodeSLAM:
        episode = self.episodes[env]
        if episode is None:
            raise RuntimeError(f"env {env} has no episode: reset() it first")
        return episode

    def _estimates(self) -> dict:
        estimates = [self._episode(env).estimate() for env in range(self.num_envs)]
        stacked = {
            key: np.array([estimate[key] for estimate in estimates])
            for key in ("pose", "pose_covariance", "particles", "effective_sample_size")
        }
        landmarks = np.empty(self.num_envs, dtype=object)
        landmarks[:] = [estimate["landmarks"] for estimate in estimates]
        return {**stacked, "landmarks": landmarks}
