"""The Gymnasium environment and its wrappers."""

import sys

import gymnasium as gym
import numpy as np
import pytest
from conftest import PROJECT_ROOT, assert_scans_match_truth_and_map
from gymnasium.utils.env_checker import check_env

import mazeslam  # noqa: F401  (registers the environments)
from mazeslam.core.motion import dead_reckoning
from mazeslam.data import log, sidecars
from mazeslam.envs.online_slam import OnlineFastSLAM
from mazeslam.envs.wrappers import RecordCourseLog
from mazeslam.evaluation.metrics import absolute_trajectory_error
from mazeslam.pipeline import slam_on_file

sys.path.insert(0, str(PROJECT_ROOT / "examples"))
from frontier_agent import FrontierAgent  # noqa: E402

IDS = [spec.id for spec in gym.registry.values() if spec.id.startswith("mazeslam/")]


def test_registered_ids():
    assert "mazeslam/Maze-v0" in IDS


@pytest.mark.parametrize("env_id", IDS)
def test_passes_gymnasiums_env_checker(env_id):
    env = gym.make(env_id)
    check_env(env.unwrapped)
    env.close()


def test_same_seed_same_episode():
    def episode(seed):
        env = gym.make("mazeslam/Maze-v0")
        env.action_space.seed(seed)
        observation, _ = env.reset(seed=seed)
        scans = [observation["scan"]]
        for _ in range(30):
            observation, *_ = env.step(env.action_space.sample())
            scans.append(observation["scan"])
        return np.array(scans)

    np.testing.assert_array_equal(episode(3), episode(3))
    assert not np.array_equal(episode(3), episode(4))


@pytest.mark.parametrize("mode", ["sync", "async"])
def test_vector_env_of_eight(mode):
    envs = gym.make_vec("mazeslam/Maze-v0", num_envs=8, vectorization_mode=mode)
    observations, infos = envs.reset(seed=0)
    assert observations["scan"].shape == (8, 180)
    for _ in range(5):
        observations, rewards, terminated, truncated, infos = envs.step(envs.action_space.sample())
    assert rewards.shape == (8,) and np.all(np.isfinite(rewards))
    assert infos["pose"].shape == (8, 3)
    envs.close()


def test_driving_into_a_wall_costs_and_stays_outside_it():
    env = gym.make("mazeslam/Maze-v0", rows=1, cols=1, collision_penalty=0.5, wall_reward=0.0, cell_reward=0.0)
    env.reset(seed=0, options={"start_cell": (0, 0), "start_heading": 0.0})
    rewards, poses = [], []
    for _ in range(30):  # full speed ahead for 3 s in a 15 cm cell
        _, reward, _, _, info = env.step(np.array([1.0, 0.0], dtype=np.float32))
        rewards.append(reward)
        poses.append(info["pose"])
    assert rewards[-1] == pytest.approx(-0.5) and info["collision"]
    body = env.unwrapped.config.robot.body_radius
    assert max(p[0] for p in poses) <= 0.15 - 0.005 - body + 1e-6


def test_exploration_reward_and_termination():
    env = gym.make("mazeslam/Maze-v0", rows=3, cols=3, max_steps=3000)
    observation, info = env.reset(seed=2)
    agent = FrontierAgent(env)
    total, steps = 0.0, 0
    while True:
        observation, reward, terminated, truncated, info = env.step(agent(observation, info))
        total, steps = total + reward, steps + 1
        if terminated or truncated:
            break
    assert terminated and info["visited"] == 1.0
    assert info["coverage"] > 0.95
    base = env.unwrapped
    expected = base.wall_reward * base.seen.sum() * 0.01 + base.cell_reward * 8  # minus any collisions
    assert total <= expected + 1e-6 and total > expected - 0.5 * steps * base.collision_penalty


@pytest.fixture(scope="module")
def frontier_log(tmp_path_factory):
    path = tmp_path_factory.mktemp("frontier") / "episode{episode}.log"
    env = RecordCourseLog(gym.make("mazeslam/Maze-v0", rows=4, cols=4, max_steps=3000), path)
    observation, info = env.reset(seed=1)
    agent = FrontierAgent(env)
    terminated = truncated = False
    while not (terminated or truncated):
        observation, _, terminated, truncated, info = env.step(agent(observation, info))
    env.close()
    return env.log_paths[0]


def test_recorded_episode_is_a_valid_log_whose_scans_match_its_sidecars(frontier_log):
    assert frontier_log.name == "episode0.log"
    assert_scans_match_truth_and_map(frontier_log)


def test_fastslam_beats_dead_reckoning_on_the_frontier_agents_log(frontier_log):
    result = slam_on_file(frontier_log, progress=False)
    _, truth = sidecars.read_truth(sidecars.truth_path(frontier_log))
    world = sidecars.read_map(sidecars.map_path(frontier_log))
    reckoned = dead_reckoning(log.read(frontier_log), world["start_pose"])
    slam_error = absolute_trajectory_error(result.mean_poses, truth)["rmse"]
    assert slam_error < 0.5 * absolute_trajectory_error(reckoned, truth)["rmse"]


def test_online_fastslam_reports_its_estimate():
    env = OnlineFastSLAM(gym.make("mazeslam/Maze-v0", rows=3, cols=3, render_mode="rgb_array"))
    observation, info = env.reset(seed=5)
    agent = FrontierAgent(env)
    for _ in range(300):
        observation, _, terminated, truncated, info = env.step(agent(observation, info))
        if terminated or truncated:
            break
    slam = info["slam"]
    assert np.hypot(*(slam["pose"][:2] - info["pose"][:2])) < 0.03
    assert slam["pose_covariance"].shape == (3, 3) and len(slam["landmarks"]) > 3
    image = env.render()
    assert image.shape[2] == 3 and image.dtype == np.uint8 and image.std() > 10


def test_rgb_array_rendering():
    env = gym.make("mazeslam/Maze-v0", render_mode="rgb_array")
    env.reset(seed=0)
    image = env.render()
    assert image.ndim == 3 and image.shape[2] == 3 and image.dtype == np.uint8
    assert len(np.unique(image.reshape(-1, 3), axis=0)) > 10  # walls, cells, robot, rays


def test_bad_arguments():
    # Gymnasium warns of a render mode the env does not list before the env refuses it.
    with pytest.raises(ValueError, match="render_mode"), pytest.warns(UserWarning, match="render_mode='video'"):
        gym.make("mazeslam/Maze-v0", render_mode="video")
    with pytest.raises(ValueError, match="action_type"):
        gym.make("mazeslam/Maze-v0", action_type="torque")


def test_human_rendering_draws_without_a_display():
    env = gym.make("mazeslam/Maze-v0", render_mode="human")
    env.reset(seed=0)
    env.step(env.action_space.sample())  # draws through matplotlib (the Agg backend here: no window)
    env.close()
