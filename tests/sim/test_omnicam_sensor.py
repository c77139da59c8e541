"""The course robot's camera range model and its simulated logs, against independent truth."""

import numpy as np
import pytest
from conftest import PROJECT_ROOT

from mazeslam.core.beams import BeamGeometry
from mazeslam.data import log, sidecars
from mazeslam.sim.laser import LaserParams, VirtualLaser
from mazeslam.sim.omnicam_sensor import OmnicamParams, OmnicamRanges, occluded_beams
from mazeslam.sim.simulator import load_config, simulate

CONFIGS = PROJECT_ROOT / "configs"
#: The exercise's mirror, written out here as the independent truth the model must follow.
HEIGHT, ALPHA = 0.126, 107.0
FORWARD = BeamGeometry(first_beam_angle=0.0)  # beam k at +k degrees, as log1


def pixel_metres(distance):
    """Floor metres one pixel covers at ``distance`` m: dd/drho = h / alpha sec^2(rho / alpha)."""
    rho = ALPHA * np.arctan(distance / HEIGHT)
    return HEIGHT / ALPHA / np.cos(rho / ALPHA) ** 2


def camera(n_beams=1, **settings) -> OmnicamRanges:
    return OmnicamRanges(OmnicamParams(**settings), FORWARD.bearings(n_beams))


def test_quantisation_step_grows_with_distance_as_the_mirror_model_says():
    true = np.linspace(0.08, 0.45, 20_000)
    reported = camera(len(true), edge_noise_px=0.0).measure(true, np.random.default_rng(0))
    levels = np.unique(reported)
    steps, middles = np.diff(levels), 0.5 * (levels[1:] + levels[:-1])
    np.testing.assert_allclose(steps, pixel_metres(middles), rtol=0.01)
    assert steps[-1] > 5 * steps[0]  # 0.4 m vs 0.1 m: about 13 mm vs 2 mm
    # Every true range is reported at the centre of its pixel: within half a pixel's step of the truth.
    assert np.all(np.abs(reported - true) <= 0.51 * pixel_metres(true))
    # ... which is h tan((k + 1/2) / alpha) for a whole k.
    pixels = ALPHA * np.arctan(reported / HEIGHT) - 0.5
    np.testing.assert_allclose(pixels, np.round(pixels), atol=1e-6)


@pytest.mark.parametrize("distance", [0.1, 0.3])
def test_edge_noise_in_pixels_becomes_range_noise_growing_with_distance(distance):
    sensor = camera(50_000, edge_noise_px=0.8, pixel_step=0.0)
    reported = sensor.measure(np.full(50_000, distance), np.random.default_rng(2))
    assert np.std(ALPHA * np.arctan(reported / HEIGHT)) == pytest.approx(0.8, rel=0.02)
    assert np.std(reported) == pytest.approx(0.8 * pixel_metres(distance), rel=0.05)


def test_no_returns_outside_the_mirror_ring_for_missing_walls_or_occluded_beams():
    params = LaserParams(
        beams=360,
        model="omnicam",
        min_range=0.11,
        max_range=1.0,
        omnicam=OmnicamParams(occluded=((350.0, 10.0),)),
        geometry=FORWARD,
    )
    laser = VirtualLaser(params, np.empty((0, 4)))
    true = np.full(360, 0.3)
    true[[90, 91, 92, 93]] = [0.05, 1.2, 2.0, np.inf]  # inside the blind disc, beyond the ring, no wall
    rng = np.random.default_rng(1)
    for _ in range(20):
        reported = laser.measure(true, rng)
        assert np.all(reported[90:94] == 0)
        occluded = np.r_[0:11, 350:360]
        assert np.all(reported[occluded] == 0)
        assert np.all(np.abs(reported[np.r_[11:90, 94:350]] - 0.3) < 0.03)


def test_the_ray_caster_reaches_as_far_as_noise_can_bring_a_wall_into_range():
    sensor = camera(10_000, edge_noise_px=0.5)
    reach = sensor.farthest_reported(1.0)
    # Six standard deviations of edge noise and a whole pixel beyond the range limit's pixel radius.
    assert ALPHA * np.arctan(reach / HEIGHT) == pytest.approx(ALPHA * np.arctan(1.0 / HEIGHT) + 3.0 + 1.0)
    assert np.all(sensor.measure(np.full(10_000, reach), np.random.default_rng(3)) > 1.0)
    assert camera(edge_noise_px=0.5).farthest_reported(100.0) == np.inf  # past the horizon


def test_occluded_sectors_are_inclusive_degrees_and_wrap_through_zero():
    bearings = FORWARD.bearings(360)
    mask = occluded_beams(bearings, ((59, 59), (258, 266), (355, 2)))
    assert np.flatnonzero(mask).tolist() == [0, 1, 2, 59, *range(258, 267), *range(355, 360)]
    with pytest.raises(ValueError, match="occluded"):
        OmnicamParams(occluded=((10.0, 400.0),))


def test_course_robot_config_simulates_a_log_that_round_trips(tmp_path):
    config = load_config(CONFIGS / "simulation_course_robot.toml")
    result = simulate(tmp_path / "course.log", config=config, seed=3, duration=60, progress=False)
    course_log = log.read(result.log_path)
    times, truth = sidecars.read_truth(result.truth_path)
    world = sidecars.read_map(result.map_path)
    assert course_log.n_beams == 360 and len(truth) == len(course_log)
    np.testing.assert_allclose(times, course_log.times)
    np.testing.assert_allclose(truth, result.poses, atol=1e-6)  # written to 6 decimals
    geometry = sidecars.beam_geometry(world["sensor"])
    assert geometry.first_beam_angle == 0.0 and geometry.mount_x == config.laser.geometry.mount_x
    assert world["sensor"]["model"] == "omnicam"
    assert world["sensor"]["omnicam"]["occluded"] == [[59, 59], [258, 266], [295, 296]]
    scans = course_log.scans
    returned = scans[scans > 0]
    assert returned.min() >= config.laser.min_range and returned.max() <= config.laser.max_range
    pixels = ALPHA * np.arctan(returned / HEIGHT) - 0.5  # whole pixels of the mirror model
    np.testing.assert_allclose(pixels, np.round(pixels), atol=1e-3)
    assert np.all(scans[:, [59, 258, 266, 295]] == 0)
    assert 0.07 < (scans == 0).mean() < 0.13  # log1: 9.4 %
    # The glitches the sidecar lists are the records the exercise's TOL_JMP (2 cm) drops.
    listed = [index for index, _ in world["odometry_glitches"]]
    jumps = np.flatnonzero(course_log.is_odometry & (np.abs(course_log.values[:, 0]) > 0.02))
    assert listed and jumps.tolist() == listed
