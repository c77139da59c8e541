"""The tiled occupancy grid: ray-traced updates, copy-on-write tiles shared by resampled particles,
and the likelihood-field matcher on it."""

import numpy as np
import pytest

from mazeslam.core.geometry import transform_points
from mazeslam.gridslam import GridSlam, GridSlamParams
from mazeslam.gridslam.filter import ScanSensor
from mazeslam.gridslam.matching import LikelihoodField, MatchParams, match_points, refine_pose
from mazeslam.gridslam.occupancy import GridParams, TiledGrid, integrate_scan, scan_rays
from mazeslam.sim.building import LASER, building_walls
from mazeslam.sim.laser import VirtualLaser

BEARINGS = LASER.geometry.bearings(LASER.beams)
MOUNT = np.zeros(2)


def insert(grid: TiledGrid, ranges: np.ndarray, pose: np.ndarray, bearings=BEARINGS) -> None:
    """Add one scan at ``pose`` to ``grid``, as the filter does."""
    rays = scan_rays(ranges, bearings, MOUNT, grid.params)
    window = grid.window(*grid.tile_range(np.vstack([transform_points(pose, rays.reach), pose[:2]]), 1.0))
    grid.store(window, integrate_scan(window, rays, pose, grid.params))


def cell_value(grid: TiledGrid, x: float, y: float) -> float:
    """The log-odds of the cell at world (x, y), m: 0 (unknown) outside every tile."""
    values, origin = grid.dense()
    i, j = np.floor((np.array([x, y]) - origin) / grid.params.resolution).astype(int)
    inside = 0 <= i < values.shape[0] and 0 <= j < values.shape[1]
    return float(values[i, j]) if inside else 0.0


def test_a_beam_clears_the_cells_it_crosses_and_marks_its_end():
    grid = TiledGrid(GridParams(max_range=5.0))
    insert(grid, np.array([2.0, 7.0]), np.zeros(3), bearings=np.array([0.0, np.pi / 2]))
    params = grid.params
    assert cell_value(grid, 1.0, 0.01) == pytest.approx(params.miss)
    assert cell_value(grid, 2.01, 0.01) == pytest.approx(params.hit)
    assert cell_value(grid, 0.01, 4.5) == pytest.approx(params.miss)  # max-range return: free up to 5 m ...
    assert cell_value(grid, 0.01, 5.02) == 0.0  # ... and nothing beyond, nothing occupied


def test_a_scans_beams_by_hand_no_return_near_return_hit_and_beyond_the_range():
    params = GridParams(max_range=5.0, min_range=0.5, resolution=0.1, trace_step=1.0)
    bearings = np.array([0.0, np.pi / 2, np.pi, -np.pi / 2])
    rays = scan_rays(np.array([0.0, 0.3, 2.0, 7.0]), bearings, MOUNT, params)  # the sensor's range unknown
    np.testing.assert_allclose(rays.hits, [[-2.0, 0.0]], atol=1e-12)  # only the 2 m return ends in a hit
    np.testing.assert_allclose(rays.reach, [[-2.0, 0.0], [0.0, -5.0]], atol=1e-12)  # the 7 m beam cut at 5 m
    behind = rays.free[rays.free[:, 0] < -1e-9]  # samples along the 2 m beam, 0.1 m apart, before its end cell
    np.testing.assert_allclose(np.sort(-behind[:, 0]), np.arange(1, 20) * 0.1, atol=1e-9)
    assert len(rays.free) == 20 + 50  # with the sensor's own sample: 2 m less half a cell, and 5 m, in 0.1 m steps


def test_a_beam_with_no_return_clears_up_to_the_sensors_maximum_range_only_when_it_is_known():
    params = GridParams(max_range=5.0, min_range=0.5)
    bearings = np.array([0.0, np.pi / 2, np.pi])
    ranges = np.array([0.0, 0.0, 0.3])  # two beams with no return, one return nearer than min_range
    unknown = scan_rays(ranges, bearings, MOUNT, params)
    assert len(unknown.free) == len(unknown.hits) == len(unknown.reach) == 0
    short = scan_rays(ranges, bearings, MOUNT, params, sensor_max_range=3.0)  # nothing within 3 m
    assert len(short.hits) == 0
    np.testing.assert_allclose(short.reach, [[3.0, 0.0], [0.0, 3.0]], atol=1e-12)  # the near return stays out
    assert 2.9 < np.hypot(*short.free.T).max() <= 3.0
    long = scan_rays(ranges, bearings, MOUNT, params, sensor_max_range=80.0)  # cut at the grid's 5 m
    np.testing.assert_allclose(long.reach, [[5.0, 0.0], [0.0, 5.0]], atol=1e-12)
    grid = TiledGrid(params)
    window = grid.window(*grid.tile_range(np.vstack([long.reach, np.zeros(2)]), 1.0))
    grid.store(window, integrate_scan(window, long, np.zeros(3), params))
    assert cell_value(grid, 4.5, 0.01) == pytest.approx(params.miss)
    assert cell_value(grid, 0.01, 4.9) == pytest.approx(params.miss)
    assert cell_value(grid, 5.1, 0.01) == 0.0 and cell_value(grid, -0.2, 0.01) == 0.0
    assert max(tile.max() for tile in grid.tiles.values()) <= 0.0  # nothing marked occupied


def test_a_copy_shares_every_tile_and_a_write_replaces_only_the_tiles_it_changes():
    grid = TiledGrid(GridParams())
    insert(grid, np.full(181, 8.0), np.array([1.6, 1.6, 0.0]))  # tiles are 3.2 m: x tiles 0 to 3
    copy = grid.copy()
    assert all(copy.tiles[key] is tile for key, tile in grid.tiles.items())
    before = {key: tile.copy() for key, tile in grid.tiles.items()}
    insert(copy, np.full(181, 1.0), np.array([8.0, 1.6, 0.0]))  # a short scan inside tile x 2
    replaced = [key for key in grid.tiles if copy.tiles[key] is not grid.tiles[key]]
    assert replaced == [(2, 0)]
    assert all(np.array_equal(grid.tiles[key], before[key]) for key in grid.tiles)  # the original is untouched


def test_resampling_copies_no_tile_and_the_cloud_costs_about_one_map():
    walls = building_walls()
    laser = VirtualLaser(LASER, walls)
    slam = GridSlam(GridSlamParams(particles=30), np.array([1.0, 1.0, 0.0]), ScanSensor(BEARINGS, MOUNT))
    rng = np.random.default_rng(0)
    for x in (1.0, 1.5, 2.0):
        slam.process(laser.scan(np.array([x, 1.0, 0.0]), rng), np.array([0.5 if x > 1.0 else 0.0, 0.0, 0.0]))
    tile_bytes = slam.params.grid.tile_size**2 * 4
    one_map = np.count_nonzero(slam.pool.table[7] >= 0) * tile_bytes
    assert slam.held_bytes() > 3 * one_map  # each particle wrote its own tiles
    slam.log_weights[:] = -1e9
    slam.log_weights[7] = 0.0  # one particle holds all the weight: every survivor descends from it
    slots_of_seven = slam.pool.table[7].copy()
    assert slam._resample_if_needed() is not None
    assert all(np.array_equal(table, slots_of_seven) for table in slam.pool.table)
    assert slam.held_bytes() == one_map


def test_the_matcher_recovers_a_displaced_pose_against_a_map():
    walls = building_walls()
    laser = VirtualLaser(LASER, walls)
    rng = np.random.default_rng(1)
    grid = TiledGrid(GridParams())
    for x in np.arange(1.0, 6.0, 0.5):
        insert(grid, laser.scan(np.array([x, 1.0, 0.0]), rng), np.array([x, 1.0, 0.0]))
    truth = np.array([4.2, 1.05, 0.02])
    ranges = laser.scan(truth, rng)
    params = MatchParams()
    points = match_points(ranges, BEARINGS, MOUNT, params)
    window = grid.window(*grid.tile_range(np.array([[0.0, 0.0], [16.0, 10.0]]), 1.0))
    field = LikelihoodField(window, params)
    found = refine_pose(field, points, truth + [0.15, -0.1, 0.04], np.eye(3) * 1e-6, params)
    assert np.hypot(*(found[:2] - truth[:2])) < 0.03
    assert abs(found[2] - truth[2]) < 0.01
    assert field.overlap(found, points, params) > 0.9


@pytest.mark.parametrize(
    ("clear", "sensor_range", "clears"), [(True, 3.0, True), (True, 0.0, False), (False, 3.0, False)]
)
def test_the_filter_clears_along_beams_with_no_return_when_asked_and_the_sensors_range_is_known(
    clear, sensor_range, clears
):
    bearings, nothing = np.radians([-20.0, 0.0, 20.0]), np.zeros(3)
    params = GridSlamParams(particles=2, grid=GridParams(clear_no_return=clear))
    slam = GridSlam(params, np.zeros(3), ScanSensor(bearings, MOUNT, max_range=sensor_range))
    slam.process(nothing, np.zeros(3))
    grid = slam.map_of(0)
    if not clears:
        assert not grid.tiles
        return
    assert cell_value(grid, 2.9, 0.01) == pytest.approx(grid.params.miss)  # nothing within 3 m ahead
    assert cell_value(grid, 3.1, 0.01) == 0.0  # and nothing said beyond
