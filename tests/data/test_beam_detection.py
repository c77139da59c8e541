"""Finding a log's beam convention from its own scans and odometry."""

import dataclasses
import math

import pytest

from mazeslam import simulate
from mazeslam.core.beams import EXERCISE_CONVENTION, BeamGeometry, SensorOverrides
from mazeslam.data import beam_detection, log
from mazeslam.data.beam_detection import detect_beam_convention, detected_geometry, with_detected_convention
from mazeslam.data.loaded_run import load_run
from mazeslam.pipeline import SlamConfig
from mazeslam.sim.laser import LaserParams
from mazeslam.sim.simulator import SimulationConfig


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


def test_a_log_without_sidecar_gets_its_convention_detected_once_then_from_the_cache(tmp_path, monkeypatch):
    laser = LaserParams(geometry=BeamGeometry(first_beam_angle=0.0, direction=1))
    config = dataclasses.replace(SimulationConfig(), laser=laser)
    simulated = simulate(tmp_path / "run.log", config=config, seed=3, duration=60, progress=False)
    bare = tmp_path / "bare.log"  # the log alone: no sidecar says how its beams point
    bare.write_bytes(simulated.log_path.read_bytes())
    run = load_run(bare)
    assert run.geometry == EXERCISE_CONVENTION
    cache = tmp_path / "beams.json"
    geometry, origin = detected_geometry(run, cache=cache)
    assert (geometry.first_beam_angle, geometry.direction) == (0.0, 1)  # snapped to the quarter turn
    assert origin.startswith("detected from the scans: beam 0 at 0 deg, direction +1")
    # The second call reads the cache: the detection itself must not run again.
    monkeypatch.setattr(beam_detection, "detect_beam_convention", lambda *args, **kwargs: pytest.fail("ran again"))
    assert detected_geometry(run, cache=cache) == (geometry, origin)
    # Other settings are another question: the cache does not answer it.
    with pytest.raises(pytest.fail.Exception, match="ran again"):
        detected_geometry(run, max_range=0.5, cache=cache)


def test_an_inconclusive_detection_keeps_the_logs_geometry(tmp_path):
    path = tmp_path / "still.log"
    path.write_text("0.0 0 0 0 -1 -1\n0.1 1 0.5 0.5 0.5 0.5\n0.2 0 0 0 -1 -1\n0.3 1 0.5 0.5 0.5 0.5\n")
    run = load_run(path)
    geometry, origin = detected_geometry(run)
    assert geometry == run.geometry
    assert "detection inconclusive" in origin and "never moves" in origin


def test_what_the_settings_give_is_kept_and_only_the_rest_detected(tmp_path):
    laser = LaserParams(geometry=BeamGeometry(first_beam_angle=math.pi / 2, direction=-1))
    config = dataclasses.replace(SimulationConfig(), laser=laser)
    simulated = simulate(tmp_path / "run.log", config=config, seed=3, duration=60, progress=False)
    bare = tmp_path / "bare.log"  # no sidecar
    bare.write_bytes(simulated.log_path.read_bytes())
    slam_config = SlamConfig()
    detected = with_detected_convention(load_run(bare), slam_config)
    assert (detected.geometry.first_beam_angle, detected.geometry.direction) == (pytest.approx(math.pi / 2), -1)
    # A first-beam angle given: nothing is detected, the geometry is the settings'.
    given = SensorOverrides(first_beam_angle=0.0)
    kept = with_detected_convention(load_run(bare, given), dataclasses.replace(slam_config, sensor=given))
    assert (kept.geometry.first_beam_angle, kept.geometry.direction) == (0.0, 1)
    # A direction given alone: kept, and only the angle detected among that direction's.
    direction_only = SensorOverrides(direction=-1)
    run = load_run(bare, direction_only)
    found = with_detected_convention(run, dataclasses.replace(slam_config, sensor=direction_only), tmp_path / "out")
    assert (found.geometry.first_beam_angle, found.geometry.direction) == (pytest.approx(math.pi / 2), -1)
    assert (tmp_path / "out" / "beam_convention.json").exists()  # the folder made for the cache
    # A log with a sidecar: its recorded convention stands.
    assert with_detected_convention(load_run(simulated.log_path), slam_config).geometry == laser.geometry
