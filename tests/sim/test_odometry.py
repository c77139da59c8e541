import numpy as np
import pytest

from mazeslam.sim.odometry import OdometryGlitches, OdometryParams, WheelEncoders
from mazeslam.sim.world import RobotParams

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


GLITCHES = OdometryParams(glitch_rate=0.05, glitch_pair_share=0.6, glitch_distance=0.06, glitch_turn=0.85)


def glitched_records(params: OdometryParams, motion: np.ndarray, seed: int = 0):
    """The records ``OdometryGlitches`` writes for the true per-record ``motion`` (R, 2), and the kinds."""
    glitches = OdometryGlitches(params, np.random.default_rng(seed))
    written = [glitches.apply(float(d), float(t)) for d, t in motion]
    return np.array([w[:2] for w in written]), [w[2] for w in written]


def test_glitches_start_at_the_configured_rate_and_share_of_pairs():
    records, kinds = glitched_records(GLITCHES, np.zeros((40_000, 2)))
    starts = kinds.count("pair_first") + kinds.count("lone")
    could_start = len(kinds) - kinds.count("pair_second")  # no glitch starts while a pair is open
    rate, pairs = starts / could_start, kinds.count("pair_first") / starts
    assert rate == pytest.approx(0.05, abs=4 * np.sqrt(0.05 * 0.95 / could_start))
    assert pairs == pytest.approx(0.6, abs=4 * np.sqrt(0.6 * 0.4 / starts))
    assert kinds.count("pair_second") == kinds.count("pair_first")


def test_a_pair_sums_to_the_true_motion_and_a_lone_jump_is_minus_two_glitch_distances():
    motion = np.random.default_rng(5).uniform(0.0, 0.008, (5000, 2))
    records, kinds = glitched_records(GLITCHES, motion, seed=1)
    error = records - motion
    for index, kind in enumerate(kinds):
        if kind is None:
            np.testing.assert_array_equal(error[index], 0.0)
        elif kind == "pair_first":
            assert kinds[index + 1] == "pair_second"
            assert error[index, 0] == pytest.approx(0.06) and abs(error[index, 1]) == pytest.approx(0.85)
            np.testing.assert_allclose(records[index] + records[index + 1], motion[index] + motion[index + 1])
        elif kind == "lone":
            np.testing.assert_allclose(error[index], [-0.12, 0.0])
    assert {"pair_first", "lone"} <= set(kinds)
    assert {np.sign(error[i, 1]) for i, kind in enumerate(kinds) if kind == "pair_first"} == {-1.0, 1.0}


def test_no_glitches_at_rate_zero_and_no_random_draws():
    rng = np.random.default_rng(0)
    glitches = OdometryGlitches(OdometryParams(), rng)
    assert all(glitches.apply(0.004, 0.01) == (0.004, 0.01, None) for _ in range(1000))
    assert rng.random() == np.random.default_rng(0).random()


@pytest.mark.parametrize("name", ["glitch_rate", "glitch_pair_share"])
def test_glitch_shares_are_probabilities(name):
    with pytest.raises(ValueError, match=name):
        OdometryParams(**{name: 1.5})
