"""Finding a log's beam convention from its own scans and odometry."""

import dataclasses
import math

import pytest

from mazeslam import log, simulate
from mazeslam.beam_detection import detect_beam_convention
from mazeslam.beams import EXERCISE_CONVENTION, BeamGeometry
from mazeslam.envs.laser import LaserParams
from mazeslam.envs.simulator import SimulationConfig


def angle_gap_degrees(a, b):
    return abs(math.degrees(math.remainder(a - b, 2 * math.pi)))


@pytest.mark.parametrize("first_beam_angle", [0.0, -math.pi, math.pi / 2])
@pytest.mark.parametrize("direction", [1, -1])
def test_finds_the_convention_a_simulated_log_was_written_with(tmp_path, first_beam_angle, direction):
    laser = LaserParams(geometry=BeamGeometry(first_beam_angle=first_beam_angle, direction=direction))
    config = dataclasses.replace(SimulationConfig(), laser=laser)
    run = simulate(tmp_path / "run.log", config=config, seed=3, duration=60, progress=False)
    detection = detect_beam_convention(log.read(run.log_path), step_degrees=2, max_pairs=20)
    assert detection.best.direction == direction
    assert angle_gap_degrees(detection.best.first_beam_angle, first_beam_angle) <= 4
    assert detection.margin > 1.3


def test_finds_beam_zero_forward_on_the_exercise_robot_log(course_log_path):
    course_log = log.read(course_log_path)
    detection = detect_beam_convention(course_log, min_range=0.05, max_range=0.4, jump_tolerance=0.02)
    assert detection.best.direction == 1
    assert angle_gap_degrees(detection.best.first_beam_angle, 0.0) <= 5
    assert detection.margin > 1.5
    # The exercise's own convention (beam 0 behind) is far worse on this log.
    assert detection.score_of(EXERCISE_CONVENTION) > 2.5 * detection.best.score


def test_a_log_where_the_robot_never_moves_says_so(tmp_path):
    path = tmp_path / "still.log"
    path.write_text("0.0 0 0 0 -1 -1\n0.1 1 0.5 0.5 0.5 0.5\n0.2 0 0 0 -1 -1\n0.3 1 0.5 0.5 0.5 0.5\n")
    with pytest.raises(ValueError, match="never moves"):
        detect_beam_convention(log.read(path))
