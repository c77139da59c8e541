"""The course robot's camera range model and its simulated logs, against independent truth."""

import math
from pathlib import Path

import numpy as np

from mazeslam import log, sidecars
from mazeslam.envs.laser import LaserParams, VirtualLaser
from mazeslam.envs.omnicam_sensor import OmnicamParams, OmnicamRanges
from mazeslam.envs.simulator import load_config, simulate

CONFIGS = Path(__file__).resolve().parents[1] / "configs"
#: The exercise's mirror, written out here as the independent truth the model must follow.
HEIGHT, ALPHA = 0.126, 107.0


def pixel_metres(distance):
    """Floor metres one pixel covers at ``distance`` m: dd/drho = h / alpha sec^2(rho / alpha)."""
    rho = ALPHA * np.arctan(distance / HEIGHT)
    return HEIGHT / ALPHA / np.cos(rho / ALPHA) ** 2


def test_quantisation_step_grows_with_distance_as_the_mirror_model_says():
    camera = OmnicamRanges(OmnicamParams(edge_noise_px=0.0, pixel_step=1.0))
    true = np.linspace(0.08, 0.45, 20_000)
    reported = camera.measure(true, np.random.default_rng(0))
    levels = np.unique(reported)
    steps, middles = np.diff(levels), 0.5 * (levels[1:] + levels[:-1])
    np.testing.assert_allclose(steps, pixel_metres(middles), rtol=0.01)
    assert steps[-1] > 5 * steps[0]  # 0.4 m vs 0.1 m: about 13 mm vs 2 mm
    # Every true range is reported at the centre of its pixel: within half a pixel's step of the truth.
    assert np.all(np.abs(reported - true) <= 0.51 * pixel_metres(true))


def test_no_returns_beyond_the_mirror_ring_or_for_missing_walls():
    params = LaserParams(beams=360, model="omnicam", min_range=0.11, max_range=1.0, omnicam=OmnicamParams())
    walls = np.array([[x, -5.0, x, 5.0] for x in (0.05, 0.3, 1.2)])  # three walls across the x axis
    laser = VirtualLaser(params, walls)
    rng = np.random.default_rng(1)
    for _ in range(20):
        reported = laser.measure(np.array([0.05, 0.3, 1.2, 2.0, np.inf]), rng)
        assert reported[0] == 0 and reported[2:].tolist() == [0.0, 0.0, 0.0]
        assert abs(reported[1] - 0.3) < 0.03


def test_course_robot_config_simulates_a_log_that_round_trips(tmp_path):
    config = load_config(CONFIGS / "simulation_course_robot.toml")
    result = simulate(tmp_path / "course.log", config=config, seed=3, duration=30, progress=False)
    course_log = log.read(result.log_path)
    times, truth = sidecars.read_truth(result.truth_path)
    world = sidecars.read_map(result.map_path)
    assert course_log.n_beams == 360 and len(truth) == len(course_log)
    np.testing.assert_allclose(times, course_log.times)
    geometry = sidecars.beam_geometry(world["sensor"])
    assert geometry.first_beam_angle == 0.0 and geometry.mount_x == 0.0
    assert world["sensor"]["model"] == "omnicam" and world["sensor"]["omnicam"]["pixel_step"] == 1.0
    scans = course_log.scans
    returned = scans[scans > 0]
    assert returned.min() >= config.laser.min_range and returned.max() <= config.laser.max_range
    # Whole pixels of the mirror model: every range is h tan((k + 1/2) / alpha) for a whole k.
    pixels = ALPHA * np.arctan(returned / HEIGHT) - 0.5
    np.testing.assert_allclose(pixels, np.round(pixels), atol=1e-3)
    assert 0.05 < (scans == 0).mean() < 0.2
    assert math.isclose(world["parameters"]["laser"]["dropout"], config.laser.dropout)
