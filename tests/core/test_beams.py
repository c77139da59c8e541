import numpy as np
import pytest

from mazeslam.core.beams import EXERCISE_CONVENTION, FORWARD_FIRST_CONVENTION, BeamGeometry


def test_exercise_convention_starts_behind():
    np.testing.assert_allclose(EXERCISE_CONVENTION.bearings(4), [np.pi, -np.pi / 2, 0, np.pi / 2], atol=1e-12)


def test_forward_first_convention_of_log1():
    bearings = FORWARD_FIRST_CONVENTION.bearings(360)
    assert bearings[0] == 0
    assert bearings[90] == pytest.approx(np.pi / 2)


def test_clockwise_direction():
    np.testing.assert_allclose(BeamGeometry(0.0, -1).bearings(4), [0, -np.pi / 2, np.pi, np.pi / 2], atol=1e-12)


def test_front_fan_spans_first_to_last_beam():
    fan = BeamGeometry(first_beam_angle=-np.pi / 2, field_of_view=np.pi)
    bearings = fan.bearings(181)
    assert bearings[0] == pytest.approx(-np.pi / 2)
    assert bearings[-1] == pytest.approx(np.pi / 2)
    assert fan.angle_step(181) == pytest.approx(np.radians(1))


@pytest.mark.parametrize("kwargs", [{"direction": 0}, {"field_of_view": 0.0}, {"field_of_view": 7.0}])
def test_impossible_geometry_is_rejected(kwargs):
    with pytest.raises(ValueError):
        BeamGeometry(**kwargs)


def test_returns_are_placed_in_the_robot_frame_from_the_mount():
    # 4 beams: 0, 90, 180, 270 deg
    geometry = BeamGeometry(first_beam_angle=0.0, direction=1, mount_x=0.1, mount_y=0.02)
    points = geometry.returns(np.array([1.0, 0.0, 2.0, 5.0]), min_range=0.5, max_range=3.0)
    # beam 1 has no return, beam 3 is beyond max_range
    np.testing.assert_allclose(points, [[1.1, 0.02], [-1.9, 0.02]], atol=1e-12)
