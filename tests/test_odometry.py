import numpy as np
import pytest

from mazeslam.envs.odometry import OdometryParams, WheelEncoders
from mazeslam.envs.world import RobotParams

ROBOT = RobotParams()


def test_noise_free_encoders_report_the_commanded_motion():
    encoders = WheelEncoders(ROBOT, OdometryParams(slip_std=0.0), np.random.default_rng(0))
    for _ in range(50):  # 1 s: left 0.03 m, right 0.05 m
        travel = encoders.drive(0.03, 0.05, 0.02)
        assert travel == pytest.approx((0.03 * 0.02, 0.05 * 0.02))
    distance, turn = encoders.read()
    step = encoders.metres_per_step
    assert distance == pytest.approx(0.04, abs=step)
    assert turn == pytest.approx(0.02 / ROBOT.wheelbase, abs=2 * step / ROBOT.wheelbase)
    assert encoders.read() == (0.0, 0.0)  # nothing moved since


def test_encoder_counts_are_whole_steps():
    encoders = WheelEncoders(ROBOT, OdometryParams(slip_std=0.0), np.random.default_rng(0))
    encoders.drive(0.01, 0.01, 0.02)  # 0.2 mm: one whole step of 0.129 mm and a part
    distance, _ = encoders.read()
    assert distance == pytest.approx(encoders.metres_per_step)


def test_slip_grows_with_the_square_root_of_travel():
    params = OdometryParams(slip_std=0.01)
    rng = np.random.default_rng(1)
    # The true ground travel of one wheel over 0.1 m, in 50 steps of 2 mm, many times.
    finals = []
    for _ in range(4000):
        encoders = WheelEncoders(ROBOT, params, rng)
        finals.append(sum(encoders.drive(0.1, 0.1, 0.02)[0] for _ in range(50)))
    assert np.mean(finals) == pytest.approx(0.1, abs=1e-4)
    assert np.std(finals) == pytest.approx(0.01 * np.sqrt(0.1), rel=0.05)


def test_systematic_scale_error_turns_a_straight_command():
    encoders = WheelEncoders(ROBOT, OdometryParams(slip_std=0.0, right_scale_error=0.01), np.random.default_rng(0))
    left, right = encoders.drive(0.05, 0.05, 1.0)
    assert right == pytest.approx(1.01 * left)
    assert encoders.read()[1] == pytest.approx(0.0, abs=1e-2)  # the odometry does not know


def test_impossible_odometry_parameters_are_rejected():
    with pytest.raises(ValueError, match="slip_std"):
        OdometryParams(slip_std=-1)
