import dataclasses

import numpy as np
import pymunk
import pytest

from mazeslam.core.beams import FORWARD_FIRST_CONVENTION, BeamGeometry
from mazeslam.sim.laser import LaserParams, VirtualLaser, cast_rays
from mazeslam.sim.maze import generate_maze
from mazeslam.sim.walls import wall_geometry

UNIT_SQUARE = np.array([[0, 0, 1, 0], [1, 0, 1, 1], [1, 1, 0, 1], [0, 1, 0, 0]], dtype=float)


def test_cast_rays_hand_computed_in_a_unit_square():
    angles = np.array([0, np.pi / 2, np.pi, -np.pi / 2, np.pi / 4])
    distances = cast_rays([0.3, 0.4], angles, UNIT_SQUARE, max_range=5.0)
    np.testing.assert_allclose(distances, [0.7, 0.6, 0.3, 0.4, 0.6 * np.sqrt(2)])


def test_cast_rays_beyond_max_range_is_inf():
    distances = cast_rays([0.3, 0.4], np.array([0.0, np.pi]), UNIT_SQUARE, max_range=0.5)
    assert distances[0] == np.inf
    assert distances[1] == pytest.approx(0.3)


def test_ray_parallel_to_a_wall_sees_the_wall_ahead():
    distances = cast_rays([0.5, 0.0], np.array([0.0]), UNIT_SQUARE[1:2], max_range=2.0)
    assert distances[0] == pytest.approx(0.5)


def free_poses(maze, count, rng):
    """Random poses inside cells, at least a robot radius from the walls."""
    cells = rng.integers([0, 0], [maze.rows, maze.cols], size=(count, 2))
    margin = maze.cell_size / 2 - maze.wall_thickness / 2 - 0.04
    centres = np.array([maze.cell_center(*cell) for cell in cells])
    return np.column_stack([centres + rng.uniform(-margin, margin, (count, 2)), rng.uniform(-np.pi, np.pi, count)])


def test_laser_agrees_with_pymunk_segment_queries_in_a_16x16_maze():
    maze = generate_maze(16, 16, 4, loop_fraction=0.1)
    walls = wall_geometry(maze)
    space = pymunk.Space()
    for xmin, ymin, xmax, ymax in walls.boxes:
        space.add(pymunk.Poly(space.static_body, [(xmin, ymin), (xmax, ymin), (xmax, ymax), (xmin, ymax)]))
    params = LaserParams(beams=180, max_range=0.8, range_noise_std=0.0)
    laser = VirtualLaser(params, walls.surfaces)
    rng = np.random.default_rng(0)
    for pose in free_poses(maze, 20, rng):
        ours = laser.true_ranges(pose)
        for bearing, distance in zip(laser.bearings, ours):
            end = pose[:2] + params.max_range * np.array([np.cos(pose[2] + bearing), np.sin(pose[2] + bearing)])
            hit = space.segment_query_first(tuple(pose[:2]), tuple(end), 0, pymunk.ShapeFilter())
            if hit is None:
                assert distance == np.inf
            else:
                assert distance == pytest.approx(hit.alpha * params.max_range, abs=1e-9)


def test_scan_noise_dropout_and_no_return():
    params = LaserParams(beams=360, max_range=0.65, range_noise_std=0.004, dropout=0.2)
    laser = VirtualLaser(params, UNIT_SQUARE)
    pose = np.array([0.3, 0.4, 0.0])
    truth = laser.true_ranges(pose)
    rng = np.random.default_rng(3)
    scans = np.array([laser.scan(pose, rng) for _ in range(200)])
    visible = np.isfinite(truth) & (truth < params.max_range - 0.03)
    returned = scans[:, visible] > 0
    assert 1 - returned.mean() == pytest.approx(params.dropout, abs=0.01)
    errors = (scans[:, visible] - truth[visible])[returned]
    assert errors.mean() == pytest.approx(0.0, abs=3e-4)
    assert errors.std() == pytest.approx(params.range_noise_std, rel=0.05)
    assert np.all(scans[:, ~np.isfinite(truth)] == 0)  # out of range: no return


def test_min_range_blanks_near_walls():
    params = LaserParams(beams=4, min_range=0.35, range_noise_std=0.0, geometry=FORWARD_FIRST_CONVENTION)
    ranges = VirtualLaser(params, UNIT_SQUARE).scan(np.array([0.3, 0.4, 0.0]), np.random.default_rng(0))
    np.testing.assert_allclose(ranges, [0.7, 0.6, 0.0, 0.4])  # forward, left, behind (0.3 < min), right


def test_mounting_offset_moves_the_sensor_ahead_of_the_axle():
    base = LaserParams(beams=8, range_noise_std=0.0, max_range=2.0)
    mounted = dataclasses.replace(base, geometry=BeamGeometry(mount_x=0.1))
    pose = np.array([0.3, 0.4, np.pi / 2])  # facing +y: the sensor sits at (0.3, 0.5)
    np.testing.assert_allclose(
        VirtualLaser(mounted, UNIT_SQUARE).true_ranges(pose),
        VirtualLaser(base, UNIT_SQUARE).true_ranges(np.array([0.3, 0.5, np.pi / 2])),
    )


@pytest.mark.parametrize(
    "kwargs",
    [{"beams": 0}, {"max_range": 0}, {"min_range": 1.0}, {"range_noise_std": -1}, {"dropout": 1.0}, {"model": "sonar"}],
)
def test_impossible_laser_parameters_are_rejected(kwargs):
    with pytest.raises(ValueError):
        LaserParams(**kwargs)


def test_ray_caster_on_oblique_walls_agrees_with_pymunk():
    """Walls at any angle, beams in any order: the angular pruning must not lose a hit."""
    rng = np.random.default_rng(7)
    segments = rng.uniform(-1, 1, (60, 4))
    space = pymunk.Space()
    for x1, y1, x2, y2 in segments:
        space.add(pymunk.Segment(space.static_body, (x1, y1), (x2, y2), 0))
    angles = rng.uniform(-4, 4, 300)  # unsorted, some beyond +-pi
    for origin in rng.uniform(-0.8, 0.8, (10, 2)):
        ours = cast_rays(origin, angles, segments, max_range=1.5)
        for angle, distance in zip(angles, ours):
            end = origin + 1.5 * np.array([np.cos(angle), np.sin(angle)])
            hit = space.segment_query_first(tuple(origin), tuple(end), 0, pymunk.ShapeFilter())
            if hit is None:
                assert distance == np.inf
            else:
                assert distance == pytest.approx(hit.alpha * 1.5, abs=1e-9)
