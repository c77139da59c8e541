import dataclasses
import math

import numpy as np
import pytest

from mazeslam.core.beams import BeamGeometry
from mazeslam.core.geometry import inverse, transform_points
from mazeslam.features.corners import CornerExtractor, CornerParams
from mazeslam.sim.laser import LaserParams, VirtualLaser

ROOM = np.array([[0, 0, 1, 0], [1, 0, 1, 1], [1, 1, 0, 1], [0, 1, 0, 0]], dtype=float)
ROOM_CORNERS = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=float)
# The room with a 0.4 m long, 2 cm thick wall sticking in from the bottom at x = 0.5.
PENINSULA = np.vstack(
    [
        [[0, 0, 0.49, 0], [0.51, 0, 1, 0], [1, 0, 1, 1], [1, 1, 0, 1], [0, 1, 0, 0]],
        [[0.49, 0, 0.49, 0.4], [0.49, 0.4, 0.51, 0.4], [0.51, 0.4, 0.51, 0]],
    ]
)


def scan(surfaces, pose, noise=0.0, seed=0, beams=180, max_range=3.0, **geometry):
    params = LaserParams(beams, max_range, range_noise_std=noise, geometry=BeamGeometry(**geometry))
    return VirtualLaser(params, surfaces).scan(np.asarray(pose, dtype=float), np.random.default_rng(seed)), params


def in_robot_frame(pose, world_points):
    return transform_points(inverse(pose), world_points)


def found(features, kinds=None):
    return np.array([[o.x, o.y] for o in features.observations if kinds is None or o.kind in kinds]).reshape(-1, 2)


def nearest_distances(a, b):
    return np.hypot(*(a[:, None, :] - b[None]).transpose(2, 0, 1)).min(axis=1)


def test_square_room_gives_its_four_corners():
    pose = [0.3, 0.4, 0.5]
    ranges, params = scan(ROOM, pose, beams=360)
    features = CornerExtractor(params.geometry, 360).extract(ranges)
    assert len(features.segments) == 4
    assert [o.kind for o in features.observations] == ["corner"] * 4
    truth = in_robot_frame(pose, ROOM_CORNERS)
    assert nearest_distances(found(features), truth).max() < 1e-6
    assert nearest_distances(truth, found(features)).max() < 1e-6


def test_range_and_bearing_agree_with_x_y():
    ranges, params = scan(ROOM, [0.3, 0.4, 0.5], beams=180)
    for o in CornerExtractor(params.geometry, 180).extract(ranges).observations:
        assert (o.range, o.bearing) == pytest.approx((math.hypot(o.x, o.y), math.atan2(o.y, o.x)))


def test_exercise_mode_reports_every_segment_end_point():
    ranges, params = scan(ROOM, [0.3, 0.4, 0.5], beams=360)
    extractor = CornerExtractor(params.geometry, 360, CornerParams(mode="endpoints"))
    features = extractor.extract(ranges)
    assert len(features.observations) == 8  # two per wall
    truth = in_robot_frame([0.3, 0.4, 0.5], ROOM_CORNERS)
    assert nearest_distances(found(features), truth).max() < 0.02  # within a beam of a corner


def test_wall_end_is_a_landmark_and_the_occluded_end_is_not():
    pose = [0.75, 0.6, math.pi]  # right of the peninsula, looking left, its tip in view
    ranges, params = scan(PENINSULA, pose, beams=360)
    corners_mode = CornerExtractor(params.geometry, 360).extract(ranges)
    endpoints_mode = CornerExtractor(params.geometry, 360, CornerParams(mode="endpoints")).extract(ranges)
    tip = in_robot_frame(pose, [[0.51, 0.4]])
    wall_ends = found(corners_mode, {"wall_end"})
    assert len(wall_ends) == 1
    assert nearest_distances(wall_ends, tip)[0] < 0.01
    occluded = [o for o in endpoints_mode.observations if o.kind == "occluded"]
    assert occluded, "the far wall's end point behind the tip is an occluded end"
    assert all(o.kind in ("corner", "wall_end") for o in corners_mode.observations)
    # Every fixed landmark is a true corner of the scene.
    true_corners = in_robot_frame(
        pose, [[0, 0], [1, 0], [1, 1], [0, 1], [0.49, 0], [0.51, 0], [0.49, 0.4], [0.51, 0.4]]
    )
    assert nearest_distances(found(corners_mode), true_corners).max() < 0.01


def test_out_of_range_ends_are_gaps_and_not_landmarks():
    pose = [0.5, 0.5, 0.0]
    ranges, params = scan(ROOM, pose, beams=360, max_range=0.6)  # the corners are 0.71 m away
    corners_mode = CornerExtractor(params.geometry, 360).extract(ranges)
    assert corners_mode.observations == []
    endpoints_mode = CornerExtractor(params.geometry, 360, CornerParams(mode="endpoints")).extract(ranges)
    assert {o.kind for o in endpoints_mode.observations} == {"gap"}


def test_front_fan_of_a_real_laser():
    pose = [0.2, 0.5, 0.0]
    geometry = dict(beams=181, first_beam_angle=-math.pi / 2, field_of_view=math.pi)
    ranges, params = scan(ROOM, pose, **geometry)
    features = CornerExtractor(params.geometry, 181).extract(ranges)
    truth = in_robot_frame(pose, [[1, 0], [1, 1]])  # the two corners ahead
    assert nearest_distances(truth, found(features, {"corner"})).max() < 1e-3
    endpoints = CornerExtractor(params.geometry, 181, CornerParams(mode="endpoints")).extract(ranges)
    assert sum(o.kind == "edge" for o in endpoints.observations) == 2  # the fan's first and last beam


@pytest.mark.parametrize("first_beam_angle, direction", [(0.0, 1), (math.pi / 2, -1), (-math.pi, 1)])
def test_any_beam_convention_and_mounting(first_beam_angle, direction):
    pose = [0.3, 0.4, 0.5]
    ranges, params = scan(ROOM, pose, beams=180, first_beam_angle=first_beam_angle, direction=direction, mount_x=0.05)
    features = CornerExtractor(params.geometry, 180).extract(ranges)
    truth = in_robot_frame(pose, ROOM_CORNERS)  # robot frame: the mounting offset is taken out
    assert len(features.observations) == 4
    assert nearest_distances(found(features), truth).max() < 1e-6


def test_reported_covariance_matches_the_scatter_of_noisy_corners():
    pose = [0.3, 0.4, 0.5]
    extractor = CornerExtractor(BeamGeometry(), 180, CornerParams())
    corner = in_robot_frame(pose, [[1.0, 1.0]])[0]
    estimates, covariances = [], []
    for seed in range(400):
        ranges, _ = scan(ROOM, pose, noise=0.003, seed=seed, beams=180)
        observations = extractor.extract(ranges).observations
        nearest = min(observations, key=lambda o: math.hypot(o.x - corner[0], o.y - corner[1]))
        estimates.append([nearest.x, nearest.y])
        covariances.append(nearest.covariance_xy)
    errors = np.array(estimates) - corner
    assert np.abs(errors.mean(axis=0)).max() < 1e-3
    # Normalised squared errors average 2 (the dimension) for a consistent covariance.
    nees = [e @ np.linalg.solve(c, e) for e, c in zip(errors, covariances)]
    assert 1.0 < np.mean(nees) < 4.0


def test_scan_of_wrong_length_is_refused():
    with pytest.raises(ValueError, match="expected a scan of 180 ranges"):
        CornerExtractor(BeamGeometry(), 180).extract(np.ones(90))


def test_empty_scan_has_no_features():
    features = CornerExtractor(BeamGeometry(), 180).extract(np.zeros(180))
    assert features.segments == [] and features.observations == []


@pytest.mark.parametrize("kwargs", [{"mode": "all"}, {"min_corner_angle": 0}, {"min_range": 2, "max_range": 1}])
def test_impossible_corner_parameters(kwargs):
    with pytest.raises(ValueError):
        dataclasses.replace(CornerParams(), **kwargs)
