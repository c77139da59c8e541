"""The vector entry point of mazeslam/Maze-v0: batched physics, one ray cast for all robots."""

import sys
import warnings
from dataclasses import replace
from types import SimpleNamespace

import gymnasium as gym
import numpy as np
import pytest
from conftest import PROJECT_ROOT
from gymnasium.vector import AutoresetMode

import mazeslam  # noqa: F401  (registers the environments)
from mazeslam.envs.maze_env import MazeEnv
from mazeslam.envs.vector_env import MazeVectorEnv, box_muller
from mazeslam.sim.laser import RayCaster
from mazeslam.sim.maze import generate_maze, parse_maze
from mazeslam.sim.simulator import SimulationConfig
from mazeslam.sim.walls import wall_geometry


def make(num_envs, **kwargs):
    return gym.make_vec("mazeslam/Maze-v0", num_envs=num_envs, vectorization_mode="vector_entry_point", **kwargs)


def run(envs, seed, actions):
    """Observations, rewards, ends and poses of an episode stream under ``actions`` (T, E, 2)."""
    observation, info = envs.reset(seed=seed)
    frames = [
        (
            observation["scan"],
            observation["odometry"],
            0 * info["coverage"],
            info["pose"],
            np.zeros(envs.num_envs, bool),
            np.zeros(envs.num_envs, bool),
        )
    ]
    for action in actions:
        observation, reward, terminated, truncated, info = envs.step(action)
        frames.append((observation["scan"], observation["odometry"], reward, info["pose"], terminated, truncated))
    return [np.array(part) for part in zip(*frames)]


def test_make_vec_gives_the_batched_env_with_batched_spaces():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        envs = make(4, rows=3, cols=5)
    assert isinstance(envs.unwrapped, MazeVectorEnv)
    assert envs.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP
    single = gym.make("mazeslam/Maze-v0")
    assert envs.single_observation_space == single.observation_space
    assert envs.single_action_space == single.action_space
    assert envs.action_space.shape == (4, 2)
    observation, info = envs.reset(seed=0)
    assert observation in envs.observation_space
    for _ in range(5):
        observation, reward, terminated, truncated, info = envs.step(envs.action_space.sample())
    assert observation in envs.observation_space
    assert reward.shape == terminated.shape == truncated.shape == (4,) and terminated.dtype == bool
    assert info["pose"].shape == (4, 3) and info["_pose"].all() and info["visited"].shape == (4,)
    assert np.all((0 < info["coverage"]) & (info["coverage"] < 1))


def test_same_maze_and_start_as_the_single_env_with_the_same_seed():
    envs = make(3, rows=5, cols=6)
    _, info = envs.reset(seed=40)
    single = MazeEnv(rows=5, cols=6)
    _, single_info = single.reset(seed=42)
    np.testing.assert_array_equal(envs.unwrapped.mazes[2].vertical, single.maze.vertical)
    np.testing.assert_array_equal(info["pose"][2], single_info["pose"])


def test_same_seed_same_episodes_and_other_seeds_others():
    actions = np.random.default_rng(0).uniform(-1, 1, (40, 3, 2))
    first, again = run(make(3), 7, actions), run(make(3), 7, actions)
    for a, b in zip(first, again):
        np.testing.assert_array_equal(a, b)
    other = run(make(3), [7, 100, 9], actions)
    np.testing.assert_array_equal(other[0][:, 0], first[0][:, 0])  # env 0: seed 7 both times
    assert not np.array_equal(other[0][:, 1], first[0][:, 1])


def test_an_env_runs_the_same_alone_as_in_a_vector_across_autoresets():
    steps, size, chosen = 120, 5, 3
    actions = np.random.default_rng(1).uniform(-1, 1, (steps, size, 2))
    together = run(make(size, rows=2, cols=2, max_steps=25), 10, actions)
    alone = run(make(1, rows=2, cols=2, max_steps=25), 10 + chosen, actions[:, chosen : chosen + 1])
    assert together[4][:, chosen].any() or together[5][:, chosen].any()  # it went through an episode end
    for part_together, part_alone in zip(together, alone):
        np.testing.assert_array_equal(part_together[:, chosen], part_alone[:, 0])


def test_box_muller_makes_independent_standard_normals():
    from scipy import stats

    normals = np.random.default_rng(0).random(200_000, dtype=np.float32)
    box_muller(normals)
    assert normals.dtype == np.float32 and np.isfinite(normals).all()
    assert stats.kstest(normals, "norm").pvalue > 0.01  # the standard normal's distribution
    assert abs(np.corrcoef(normals[:100_000], normals[100_000:])[0, 1]) < 0.01  # a pair's two halves
    assert abs(np.corrcoef(normals[:-1], normals[1:])[0, 1]) < 0.01  # neighbours
    rows = np.random.default_rng(1).random((5, 6080), dtype=np.float32)
    one_by_one = rows.copy()
    for row in one_by_one:
        box_muller(row)
    box_muller(rows)  # all at once, as the vector env does when every env refills
    np.testing.assert_array_equal(rows, one_by_one)


def test_next_step_autoreset():
    envs = make(2, max_steps=3)
    envs.reset(seed=0)
    action = np.zeros((2, 2), dtype=np.float32)
    for _ in range(2):
        _, _, _, truncated, _ = envs.step(action)
    assert not truncated.any()
    _, reward, terminated, truncated, info = envs.step(np.ones((2, 2), dtype=np.float32))
    assert truncated.all() and not terminated.any()
    observation, reward, terminated, truncated, info = envs.step(np.ones((2, 2), dtype=np.float32))
    np.testing.assert_array_equal(reward, 0.0)
    assert not (terminated | truncated).any() and np.all(info["time"] == 0.0)
    np.testing.assert_array_equal(observation["odometry"], 0.0)
    np.testing.assert_array_equal(info["pose"], envs.unwrapped.start_poses)


def test_reset_mask_resets_only_the_chosen_envs():
    envs = make(3)
    envs.reset(seed=0)
    for _ in range(3):
        envs.step(np.ones((3, 2), dtype=np.float32))
    before = envs.unwrapped.poses.copy()
    _, info = envs.reset(seed=50, options={"reset_mask": np.array([False, True, False])})
    np.testing.assert_array_equal(info["_pose"], [False, True, False])
    np.testing.assert_array_equal(envs.unwrapped.poses[[0, 2]], before[[0, 2]])
    assert envs.unwrapped.steps.tolist() == [3, 0, 3]
    with pytest.raises(ValueError, match="every env"):
        envs.reset(options={"rows": 7, "reset_mask": np.array([True, False, False])})


def test_terminates_when_every_cell_is_visited():
    envs = make(2, rows=1, cols=1)
    envs.reset(seed=0)
    _, _, terminated, truncated, info = envs.step(np.zeros((2, 2), dtype=np.float32))
    assert terminated.all() and not truncated.any() and np.all(info["visited"] == 1.0)


def distance_to_walls(points: np.ndarray, boxes: np.ndarray) -> np.ndarray:
    """(P,) metres from each point (P, 2) to the nearest of the boxes (B, 4)."""
    nearest_x = np.clip(points[:, :1], boxes[:, 0], boxes[:, 2])
    nearest_y = np.clip(points[:, 1:], boxes[:, 1], boxes[:, 3])
    return np.hypot(points[:, :1] - nearest_x, points[:, 1:] - nearest_y).min(axis=1)


def test_random_driving_never_enters_a_wall():
    envs = make(16, rows=3, cols=3, max_steps=10_000, collision_penalty=1.0)
    envs.reset(seed=3)
    base = envs.unwrapped
    boxes = [wall_geometry(maze).boxes for maze in base.mazes]
    radius = base.config.robot.body_radius
    rng = np.random.default_rng(3)
    closest, collisions = np.inf, 0
    for _ in range(600):
        action = rng.uniform(-1, 1, (16, 2)) * [1.0, 0.3] + [0.6, 0.0]  # mostly ahead: into walls
        _, reward, _, _, info = envs.step(action)
        collisions += info["collision"].sum()
        closest = min(closest, min(distance_to_walls(info["pose"][k : k + 1, :2], boxes[k])[0] for k in range(16)))
    assert collisions > 100  # the robots did drive into walls
    assert closest >= radius - 1e-9


def test_ranges_in_a_single_cell_are_the_distances_to_its_inner_faces():
    config = SimulationConfig(laser=replace(SimulationConfig().laser, range_noise_std=0.0))
    envs = make(1, rows=1, cols=1, config=config)
    observation, _ = envs.reset(seed=0, options={"start_cell": (0, 0), "start_heading": 0.3})
    bearings = envs.unwrapped.bearings + 0.3
    half_width = 0.15 / 2 - 0.01 / 2  # from the cell centre to the inner wall faces
    expected = half_width / np.maximum(np.abs(np.cos(bearings)), np.abs(np.sin(bearings)))
    np.testing.assert_allclose(observation["scan"][0], expected, atol=1e-6)


@pytest.mark.parametrize("per_maze", [1, 60])  # 60 sensors a maze: the many-rays path (own cells, passes)
def test_batched_ray_cast_matches_the_segment_ray_caster(per_maze):
    mazes = [generate_maze(8, 8, seed, loop_fraction=0.3) for seed in range(4)]
    envs = MazeVectorEnv(num_envs=4, rows=8, cols=8)
    envs.reset(seed=0)
    for index, maze in enumerate(mazes):
        envs.grids.set(index, maze)
    rng = np.random.default_rng(0)
    sensors = np.repeat(np.arange(4), per_maze)
    x, y = rng.uniform(0.02, 1.18, (2, len(sensors)))  # anywhere, in walls' gaps and near corners too
    heading = rng.uniform(-np.pi, np.pi, len(sensors))
    ranges, _, _ = envs.grids.cast_edges(sensors, x, y, heading, envs.bearings, 0.8)
    checked = 0
    for k, index in enumerate(sensors):
        geometry = wall_geometry(mazes[index])
        if distance_to_walls(np.array([[x[k], y[k]]]), geometry.boxes)[0] > 0:  # free space
            caster = RayCaster(geometry.surfaces, envs.bearings, 0.8)
            np.testing.assert_allclose(ranges[k], caster.cast(x[k], y[k], heading[k]), atol=1e-12)
            checked += 1
    assert checked >= 0.8 * len(sensors)


def test_a_wall_seen_whole_counts_its_length():
    maze = parse_maze("+--+\n|  |\n+--+\n")
    envs = make(1, maze=maze, wall_reward=1.0, cell_reward=0.0)
    _, info = envs.reset(seed=0)
    assert info["coverage"][0] == pytest.approx(1.0, abs=0.05)  # one cell: every face in view at once


def test_rgb_array_rendering_tiles_the_chosen_envs():
    envs = make(4, render_mode="rgb_array", render_envs=(0, 1, 2))
    envs.reset(seed=0)
    image = envs.render()
    single = MazeVectorEnv(num_envs=1, render_mode="rgb_array")
    single.reset(seed=0)
    one = single.render()
    assert image.shape == (2 * one.shape[0], 2 * one.shape[1], 3) and image.dtype == np.uint8
    np.testing.assert_array_equal(image[: one.shape[0], : one.shape[1]], one)


def test_course_logs_of_every_env_and_episode(tmp_path):
    from conftest import assert_scans_match_truth_and_map

    from mazeslam.envs.wrappers import RecordVectorCourseLogs

    envs = RecordVectorCourseLogs(make(2, rows=2, cols=2, max_steps=15), tmp_path / "env{env}-ep{episode}.log")
    envs.reset(seed=0)
    rng = np.random.default_rng(0)
    for _ in range(20):  # through one autoreset
        envs.step(rng.uniform(-1, 1, (2, 2)) * [0.5, 1.0] + [0.5, 0.0])
    envs.close()
    assert sorted(path.name for path in envs.log_paths) == [
        "env0-ep0.log",
        "env0-ep1.log",
        "env1-ep0.log",
        "env1-ep1.log",
    ]
    for path in envs.log_paths:
        assert_scans_match_truth_and_map(path)


def frontier_agents(envs):
    """A ``FrontierAgent`` (examples/frontier_agent.py) per env of a vector, for its current maze."""
    sys.path.insert(0, str(PROJECT_ROOT / "examples"))
    from frontier_agent import FrontierAgent

    base = envs.unwrapped
    return [
        FrontierAgent(
            SimpleNamespace(
                unwrapped=SimpleNamespace(
                    maze=maze,
                    laser=SimpleNamespace(bearings=base.bearings),
                    config=base.config,
                    top_turn_rate=base.top_turn_rate,
                )
            )
        )
        for maze in base.mazes
    ]


def test_online_fastslam_on_every_env():
    from mazeslam.envs.online_slam import VectorOnlineFastSLAM

    envs = VectorOnlineFastSLAM(make(2, rows=4, cols=4, max_steps=1000))
    observation, info = envs.reset(seed=5)
    agents = frontier_agents(envs)
    for _ in range(300):
        actions = [agent({"scan": observation["scan"][k]}, {"pose": info["pose"][k]}) for k, agent in enumerate(agents)]
        observation, _, terminated, truncated, info = envs.step(np.array(actions))
        if (terminated | truncated).any():  # an env explored its maze; the estimates are still this episode's
            break
    slam = info["slam"]
    assert slam["pose"].shape == (2, 3) and slam["pose_covariance"].shape == (2, 3, 3)
    assert np.all(np.hypot(*(slam["pose"][:, :2] - info["pose"][:, :2]).T) < 0.03)
    assert all(len(landmarks) > 3 for landmarks in slam["landmarks"])
