"""Issue 36, items 4, 6 and 11: the envs refuse what is outside their spaces and ranges, clearly
and at once (never a hang, never a numpy error), and the recorders lose no episode."""

import subprocess
import sys
import textwrap
import threading
import time

import gymnasium as gym
import numpy as np
import pytest
from conftest import PROJECT_ROOT, assert_scans_match_truth_and_map

import mazeslam  # noqa: F401  (registers the environments)
from mazeslam.data import log, sidecars
from mazeslam.envs.maze_env import MazeEnv
from mazeslam.envs.vector_env import MazeVectorEnv
from mazeslam.envs.wrappers import RecordCourseLog, RecordVectorCourseLogs, episode_path


def call_with_deadline(function, seconds=10.0):
    """``function()``'s exception (None if it returned) and its duration; fails the test instead of
    hanging when it has not returned after ``seconds``."""
    outcome = {}

    def target():
        began = time.perf_counter()
        try:
            function()
            outcome["error"] = None
        except Exception as error:  # noqa: BLE001  (the test looks at it)
            outcome["error"] = error
        outcome["seconds"] = time.perf_counter() - began

    thread = threading.Thread(target=target, daemon=True)
    thread.start()
    thread.join(seconds)
    if thread.is_alive():
        pytest.fail(f"still running after {seconds} s: it hangs")
    return outcome["error"], outcome["seconds"]


def make_vec(num_envs, **kwargs):
    return gym.make_vec("mazeslam/Maze-v0", num_envs=num_envs, vectorization_mode="vector_entry_point", **kwargs)


# -- item 4: NaN actions ----------------------------------------------------------------------------
def test_vector_env_refuses_a_nan_row_at_once_instead_of_hanging():
    # The reproducer: make_vec(num_envs=4), one row of actions NaN (a diverging policy).
    envs = make_vec(4)
    envs.reset(seed=0)
    actions = np.zeros((4, 2), dtype=np.float32)
    actions[1] = np.nan
    error, seconds = call_with_deadline(lambda: envs.step(actions))
    assert isinstance(error, ValueError) and seconds < 1.0
    message = str(error)
    assert "env 1" in message and "NaN or infinite" in message and "Box(-1.0, 1.0, (4, 2), float32)" in message
    # Nothing moved: the next finite step goes on from the reset.
    before = envs.unwrapped.poses.copy()
    _, reward, *_, info = envs.step(np.zeros((4, 2), dtype=np.float32))
    assert np.isfinite(reward).all() and np.isfinite(info["pose"]).all()
    assert envs.unwrapped.steps.tolist() == [1, 1, 1, 1]
    assert np.abs(info["pose"] - before).max() < 0.01


@pytest.mark.parametrize(
    "actions, message",
    [
        (np.full((3, 2), np.inf), "envs 0, 1, 2"),
        (np.zeros((3, 3)), r"shape \(3, 3\)"),
        (np.zeros(6), r"shape \(6,\)"),
        ("left", "not an array of numbers"),
    ],
)
def test_vector_env_refuses_infinite_or_misshapen_actions(actions, message):
    envs = make_vec(3)
    envs.reset(seed=1)
    with pytest.raises(ValueError, match=message) as refused:
        envs.step(actions)
    assert "Box(-1.0, 1.0, (3, 2), float32)" in str(refused.value)


@pytest.mark.parametrize(
    "action, message",
    [
        ([np.nan, 0.0], r"action \[nan, 0.0\] has a NaN or infinite value"),
        ([0.5, np.inf], r"action \[0.5, inf\] has a NaN or infinite value"),
        ([0.1, 0.2, 0.3], r"action of shape \(3,\) does not fit"),
        ([[0.1, 0.2]], r"action of shape \(1, 2\) does not fit"),
        (0.5, r"action of shape \(\) does not fit"),
        ("ab", "is not an array of numbers"),
    ],
)
def test_single_env_refuses_actions_outside_its_space(action, message):
    env = gym.make("mazeslam/Maze-v0")
    env.reset(seed=0)
    with pytest.raises(ValueError, match=message) as refused:
        env.step(action)
    assert "Box(-1.0, 1.0, (2,), float32)" in str(refused.value)
    assert env.unwrapped.steps == 0  # not counted; the episode goes on
    _, reward, *_, info = env.step(np.array([0.5, 0.0], dtype=np.float32))
    assert np.isfinite(reward) and np.isfinite(info["pose"]).all()


def test_finite_actions_beyond_the_bounds_are_still_clipped():
    env = MazeEnv()
    env.reset(seed=3)
    big = env.step(np.array([5.0, -7.0]))[4]["pose"]
    env.reset(seed=3)
    clipped = env.step(np.array([1.0, -1.0]))[4]["pose"]
    np.testing.assert_array_equal(big, clipped)


# -- item 11: reset options, settings, step before reset, huge mazes --------------------------------
@pytest.mark.parametrize(
    "options, message",
    [
        ({"start_cell": (100, 100)}, r"options\['start_cell'\] must be \(row, col\) of a cell of the 4 x 4 maze, "),
        ({"start_cell": (-1, 0)}, r"0 <= row < 4 and 0 <= col < 4, got \(-1, 0\)"),
        ({"start_cell": (0.5, 1)}, r"options\['start_cell'\]"),
        ({"start_cell": (1,)}, r"options\['start_cell'\]"),
        ({"rows": 2, "start_cell": (3, 0)}, "of the 2 x 4 maze"),
        ({"start_heading": float("nan")}, r"options\['start_heading'\] must be a finite number of radians"),
        ({"rows": 0}, r"options\['rows'\] must be a whole number of cells, at least 1, got 0"),
        ({"rows": 200, "cols": 200}, "a 200 x 200 maze has 40000 cells.*at most 10000 cells"),
        ({"loop_fraction": float("nan")}, r"options\['loop_fraction'\] must be a number in \[0, 1\]"),
        ({"maze": 3}, r"options\['maze'\] must be a Maze, a maze file or 'random'"),
        ({"start_cel": (0, 0)}, "unknown reset option 'start_cel': mazeslam/Maze-v0 takes maze, rows, cols"),
    ],
)
@pytest.mark.parametrize("vector", [False, True], ids=["single", "vector"])
def test_bad_reset_options_are_refused_naming_the_option_and_its_range(options, message, vector):
    env = make_vec(2) if vector else gym.make("mazeslam/Maze-v0")
    env.reset(seed=0)
    base = env.unwrapped
    before = (base.poses if vector else base.simulated.pose).copy()
    error, _ = call_with_deadline(lambda: env.reset(seed=5, options=options))  # a NaN heading hung the cast
    assert isinstance(error, ValueError)
    with pytest.raises(ValueError, match=message):
        raise error
    # A refused reset changes nothing: the episode goes on where it was.
    np.testing.assert_array_equal(base.poses if vector else base.simulated.pose, before)


def test_a_start_cell_inside_the_maze_is_where_the_robot_starts():
    env = gym.make("mazeslam/Maze-v0", rows=3, cols=5)
    _, info = env.reset(seed=0, options={"start_cell": np.array([2, 4]), "start_heading": 0.5})
    np.testing.assert_allclose(info["pose"], [4.5 * 0.15, 2.5 * 0.15, 0.5])


@pytest.mark.parametrize(
    "settings, message",
    [
        ({"wall_reward": float("nan")}, "wall_reward must be a finite number, got nan"),
        ({"cell_reward": float("inf")}, "cell_reward must be a finite number, got inf"),
        ({"collision_penalty": "high"}, "collision_penalty must be a finite number"),
        ({"rows": 200, "cols": 200}, "rows x cols: a 200 x 200 maze has 40000 cells.*at most 10000 cells"),
        ({"cols": 2.5}, "cols must be a whole number of cells"),
        ({"loop_fraction": 1.5}, r"loop_fraction must be a number in \[0, 1\], got 1.5"),
    ],
)
@pytest.mark.parametrize("vector", [False, True], ids=["single", "vector"])
def test_bad_settings_are_refused_at_construction(settings, message, vector):
    began = time.perf_counter()
    with pytest.raises(ValueError, match=message):
        MazeVectorEnv(num_envs=2, **settings) if vector else MazeEnv(**settings)
    assert time.perf_counter() - began < 1.0  # before any maze is drawn


def test_vector_env_stepped_before_reset_says_so():
    envs = make_vec(2)
    with pytest.raises(RuntimeError, match=r"call reset\(\) before step\(\)"):
        envs.step(np.zeros((2, 2), dtype=np.float32))
    with pytest.raises(ValueError, match=r"the first reset\(\) must reset every env"):
        envs.reset(options={"reset_mask": np.array([True, False])})
    envs.reset(seed=0)  # then it works
    envs.step(np.zeros((2, 2), dtype=np.float32))


def test_a_100_by_100_maze_resets_in_linear_memory():
    # A 200 x 200 maze took 21 s and 4.4 GB per reset: a cells x surfaces table in WallsInSight.
    # It is refused now (above MAX_MAZE_CELLS); the largest allowed one stays light.
    import tracemalloc

    env = MazeEnv(rows=100, cols=100)
    tracemalloc.start()
    try:
        env.reset(seed=0)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < 150e6  # the cells x surfaces table alone was 10000 x ~30000 bytes = 300 MB
    _, reward, *_ = env.step(np.array([0.5, 0.0]))
    assert np.isfinite(reward)


# -- item 6: recorded episodes are kept -------------------------------------------------------------
def drive(env, episodes, steps=12):
    for episode in range(episodes):
        env.reset(seed=episode)
        for _ in range(steps):
            _, _, terminated, truncated, _ = env.step(np.array([0.6, 0.3], dtype=np.float32))
            if terminated or truncated:
                break


def test_a_path_without_episode_keeps_every_episode(tmp_path):
    # The reproducer: RecordCourseLog(env, "runs/agent.log"), 3 episodes: one log, overwritten.
    env = RecordCourseLog(gym.make("mazeslam/Maze-v0", max_episode_steps=10), tmp_path / "runs" / "agent.log")
    drive(env, 3)
    env.close()
    names = ["agent.log", "agent-1.log", "agent-2.log"]
    assert [path.name for path in env.log_paths] == names
    starts = set()
    for path in env.log_paths:
        course_log = log.read(path)
        assert len(course_log) == 2 * 11  # the reset's scan and 10 steps' odometry and scan
        assert_scans_match_truth_and_map(path)
        starts.add(tuple(sidecars.read_map(sidecars.map_path(path))["start_pose"]))
    assert len(starts) == 3  # three episodes, not one three times


def test_episode_paths():
    assert episode_path("runs/a.log", 0) == episode_path("runs/a{episode}.log", 0).with_name("a.log")
    assert str(episode_path("runs/a.log", 2)) == "runs/a-2.log"
    assert str(episode_path("runs/a{episode:03d}.log", 2)) == "runs/a002.log"
    assert str(episode_path("runs/v.log", 0, env=3)) == "runs/v-env3.log"
    assert str(episode_path("runs/v.log", 1, env=3)) == "runs/v-env3-1.log"
    assert str(episode_path("runs/e{env}.log", 1, env=3)) == "runs/e3-1.log"
    with pytest.raises(ValueError, match=r"only \{episode\} may stand in braces"):
        RecordCourseLog(gym.make("mazeslam/Maze-v0"), "runs/{agent}.log")
    with pytest.raises(ValueError, match=r"only \{episode\} may stand in braces"):
        RecordCourseLog(gym.make("mazeslam/Maze-v0"), "runs/{env}.log")


def test_vector_recorder_without_env_or_episode_overwrites_nothing(tmp_path):
    envs = RecordVectorCourseLogs(make_vec(2, rows=2, cols=2, max_steps=6), tmp_path / "v.log")
    envs.reset(seed=0)
    for _ in range(10):  # through one autoreset
        envs.step(np.full((2, 2), 0.4, dtype=np.float32))
    envs.close()
    assert sorted(path.name for path in envs.log_paths) == ["v-env0-1.log", "v-env0.log", "v-env1-1.log", "v-env1.log"]
    for path in envs.log_paths:
        assert_scans_match_truth_and_map(path)


def test_a_script_that_dies_before_close_keeps_its_episodes(tmp_path):
    # The reproducer: a script that dies before close() lost the truth and map sidecars.
    script = textwrap.dedent(
        f"""
        import os, sys
        import gymnasium as gym
        import numpy as np
        sys.path.insert(0, {str(PROJECT_ROOT)!r})
        import mazeslam
        from mazeslam.envs.wrappers import RecordCourseLog

        env = RecordCourseLog(gym.make("mazeslam/Maze-v0", max_episode_steps=8), {str(tmp_path / "ep{episode}.log")!r})
        for episode in range(3):
            env.reset(seed=episode)
            for _ in range(8):
                env.step(np.array([0.6, 0.3], dtype=np.float32))
        env.reset(seed=3)
        for _ in range(4):  # the fourth episode, cut short
            env.step(np.array([0.6, 0.3], dtype=np.float32))
        os._exit(3)  # dies: no close(), no exit handlers
        """
    )
    process = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert process.returncode == 3, process.stderr
    for episode, records in [(0, 18), (1, 18), (2, 18), (3, 10)]:
        path = tmp_path / f"ep{episode}.log"
        assert len(log.read(path)) == records
        times, poses = sidecars.read_truth(sidecars.truth_path(path))
        assert len(times) == records and np.isfinite(poses).all()
        assert_scans_match_truth_and_map(path)
