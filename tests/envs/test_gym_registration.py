"""The Gymnasium registration: TimeLimit from ``max_episode_steps``, the env not truncating itself
on top of it, and the examples' --render and --video."""

import os
import subprocess
import sys

import gymnasium as gym
import pytest
from conftest import PROJECT_ROOT

import mazeslam


def test_registered_with_max_episode_steps():
    spec = gym.spec("mazeslam/Maze-v0")
    assert spec.max_episode_steps == mazeslam.MAX_EPISODE_STEPS == 3000
    env = gym.make("mazeslam/Maze-v0", rows=2, cols=2)
    assert env.spec.max_episode_steps == 3000
    assert env.unwrapped.max_steps is None  # the TimeLimit truncates, not the env
    env.close()


def test_max_episode_steps_is_the_one_limit():
    env = gym.make("mazeslam/Maze-v0", rows=3, cols=3, max_episode_steps=4)
    env.reset(seed=0)
    ends = [env.step(env.action_space.sample() * 0)[3] for _ in range(4)]
    assert ends == [False, False, False, True]
    env.close()
    # Made directly (no gym.make): max_steps truncates instead.
    from mazeslam.envs.maze_env import MazeEnv

    direct = MazeEnv(rows=3, cols=3, max_steps=2)
    direct.reset(seed=0)
    assert [direct.step([0.0, 0.0])[3] for _ in range(2)] == [False, True]


def run_example(name, *args, cwd):
    environment = {**os.environ, "MPLBACKEND": "Agg"}
    return subprocess.run(
        [sys.executable, str(PROJECT_ROOT / "examples" / name), *args],
        capture_output=True,
        text=True,
        cwd=cwd,
        env=environment,
        timeout=300,
    )


@pytest.mark.parametrize("name", ["random_agent.py", "frontier_agent.py"])
def test_examples_take_render(name, tmp_path):
    process = run_example(name, "--steps", "5", "--render", cwd=tmp_path)
    assert process.returncode == 0, process.stderr
    assert "5 steps" in process.stdout


def test_example_video_with_moviepy(tmp_path):
    pytest.importorskip("moviepy")
    process = run_example("random_agent.py", "--steps", "20", "--video", "videos", cwd=tmp_path)
    assert process.returncode == 0, process.stderr
    videos = list((tmp_path / "videos").glob("*.mp4"))
    assert videos and videos[0].stat().st_size > 1000


def test_vector_env_truncates_at_max_episode_steps():
    envs = gym.make_vec(
        "mazeslam/Maze-v0", num_envs=2, vectorization_mode="vector_entry_point", rows=2, cols=2, max_episode_steps=3
    )
    assert envs.unwrapped.max_steps == 3
    envs.close()
    envs = gym.make_vec("mazeslam/Maze-v0", num_envs=2, vectorization_mode="vector_entry_point", rows=2, cols=2)
    assert envs.unwrapped.max_steps == 3000
    envs.close()
