"""The Gymnasium environment on a real robot, here a scripted stand-in: no world, no truth."""

import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from mazeslam.envs.hardware_env import HardwareMazeEnv
from mazeslam.robot.interface import Robot


class ScriptedRobot(Robot):
    """Drives nowhere: reports 0.1 mm forward per odometry read and the same scan every time."""

    def __init__(self, beams: int = 180):
        self.speeds, self.odometry_reads = (0.0, 0.0), 0
        self.scan = np.linspace(0.0, 0.5, beams)

    def set_wheel_speeds(self, left: float, right: float) -> None:
        self.speeds = (left, right)

    def read_odometry(self) -> tuple[float, float]:
        self.odometry_reads += 1
        return 0.0001, 0.0

    def read_scan(self) -> np.ndarray:
        return self.scan


def test_passes_gymnasiums_env_checker():
    check_env(HardwareMazeEnv(ScriptedRobot(), control_period=0.001), skip_render_check=True)


def test_observes_the_robot_without_reward_truth_or_end():
    robot = ScriptedRobot()
    env = HardwareMazeEnv(robot, max_steps=3, control_period=0.001, action_type="wheels")
    with pytest.raises(RuntimeError, match="reset"):
        env.step(np.zeros(2, dtype=np.float32))
    observation, info = env.reset()
    assert robot.odometry_reads == 1 and info == {"time": 0.0}  # the motion before the episode is forgotten
    np.testing.assert_array_equal(observation["odometry"], [0.0, 0.0])
    for step in range(1, 4):
        observation, reward, terminated, truncated, info = env.step(np.array([0.5, -2.0], dtype=np.float32))
        assert reward == 0.0 and not terminated and truncated == (step == 3)
        assert info == {"time": pytest.approx(0.001 * step)}
    assert robot.speeds == pytest.approx((0.065, -0.13))  # fractions of the top wheel speed, clipped
    assert observation["odometry"][0] == pytest.approx(0.0001)
    np.testing.assert_array_equal(observation["scan"], robot.scan.astype(np.float32))
    assert env.observation_space.contains(observation)
