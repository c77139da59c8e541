import numpy as np
import pytest

from mazeslam.sim.maze import parse_maze
from mazeslam.sim.walls import wall_geometry
from mazeslam.sim.world import RobotParams, World

ROOM = parse_maze("cell_size = 0.5\nwall_thickness = 0.01\n+---+\n|   |\n+---+\n")


def drive(world, left_speed, right_speed, seconds, dt=0.02):
    for _ in range(round(seconds / dt)):
        world.step(left_speed * dt, right_speed * dt, dt)


def test_equal_wheel_speeds_drive_straight():
    world = World(wall_geometry(ROOM).boxes, RobotParams(), [0.1, 0.25, 0.0])
    drive(world, 0.05, 0.05, 2.0)
    np.testing.assert_allclose(world.pose, [0.2, 0.25, 0.0], atol=1e-9)


def test_opposite_wheel_speeds_turn_on_the_spot():
    robot = RobotParams()
    world = World(wall_geometry(ROOM).boxes, robot, [0.25, 0.25, 0.0])
    # Wheel speed v turns the body at 2 v / wheelbase.
    seconds = (np.pi / 2) / (2 * 0.02 / robot.wheelbase)
    drive(world, -0.02, 0.02, seconds, dt=seconds / 100)
    np.testing.assert_allclose(world.pose, [0.25, 0.25, np.pi / 2], atol=1e-9)


def test_robot_never_passes_through_a_wall():
    robot = RobotParams()
    world = World(wall_geometry(ROOM).boxes, robot, [0.25, 0.25, 0.3])
    wall_face = 0.5 - 0.005
    for _ in range(1000):  # 20 s at full speed against the right-hand wall
        world.step(robot.max_wheel_speed * 0.02, robot.max_wheel_speed * 0.02, 0.02)
        assert world.pose[0] <= wall_face - robot.body_radius + 1e-9
    assert world.pose[1] > 0.3  # it slid along the wall instead of stopping dead or tunnelling


def test_wheel_speed_saturation_keeps_curvature():
    robot = RobotParams()
    left, right = robot.wheel_speeds(0.2, 2.0)
    assert max(abs(left), abs(right)) == pytest.approx(robot.max_wheel_speed)
    curvature = (right - left) / robot.wheelbase / (0.5 * (left + right))
    assert curvature == pytest.approx(2.0 / 0.2)
    assert robot.wheel_speeds(0.05, 0.0) == (0.05, 0.05)


def test_impossible_robot_parameters_are_rejected():
    with pytest.raises(ValueError, match="wheelbase"):
        RobotParams(wheelbase=0)
