"""The tile pool that holds every particle's map: windows read as the tiled grid gives them,
copy-on-write shared tiles, growth when free slots run out."""

import numpy as np

from mazeslam.core.geometry import transform_points
from mazeslam.gridslam.occupancy import GridParams, TiledGrid, integrate_scan, scan_rays, tile_range
from mazeslam.gridslam.tile_pool import TilePool

PARAMS = GridParams(resolution=0.1, tile_size=8)  # tiles of 0.8 m
BEARINGS = np.linspace(-np.pi, np.pi, 73)[:-1]


def scan(pool: TilePool, ranges: np.ndarray, poses: np.ndarray) -> None:
    """Add one scan of ``ranges`` to every particle of ``pool``, each at its pose of ``poses`` (P, 3),
    within the window its reach needs (as the filter adds it)."""
    rays = scan_rays(ranges, BEARINGS, np.zeros(2), PARAMS)
    reach = np.stack([np.vstack([transform_points(pose, rays.reach), pose[:2]]) for pose in poses])
    lowers, uppers = tile_range(reach, 0.5, pool.tile_metres)
    pool.cover(lowers.min(axis=0), uppers.max(axis=0))
    pool.integrate(rays, poses, lowers, uppers)


def grid_scan(grid: TiledGrid, ranges: np.ndarray, pose: np.ndarray) -> None:
    """The same scan into a ``TiledGrid`` (the filter's maps before the pool)."""
    rays = scan_rays(ranges, BEARINGS, np.zeros(2), PARAMS)
    reach = np.vstack([transform_points(pose, rays.reach), pose[:2]])
    window = grid.window(*grid.tile_range(reach, 0.5))
    grid.store(window, integrate_scan(window, rays, pose, PARAMS))


def test_scans_written_to_the_pool_give_the_maps_of_the_tiled_grid_at_any_capacity():
    rng = np.random.default_rng(0)
    poses = np.array([[0.3, -0.2, 0.4], [-1.1, 2.05, -2.0], [0.0, 0.0, 0.0]])
    small, large = TilePool(PARAMS, 3, capacity=1), TilePool(PARAMS, 3, capacity=500)
    grids = [TiledGrid(PARAMS) for _ in poses]
    for _ in range(3):
        ranges = rng.uniform(0.2, 2.5, len(BEARINGS))
        poses = poses + rng.normal(0, 0.3, poses.shape)
        scan(small, ranges, poses)
        scan(large, ranges, poses)
        for grid, pose in zip(grids, poses):
            grid_scan(grid, ranges, pose)
    assert len(small.tiles) > 1  # it grew
    for particle, grid in enumerate(grids):
        for pool in (small, large):
            got, expected = pool.grid(particle), grid
            assert got.tiles.keys() == expected.tiles.keys()
            assert all(np.array_equal(got.tiles[key], expected.tiles[key]) for key in expected.tiles)
            window = pool.window(particle, np.array([-4, -3]), np.array([3, 5]))
            expected_window = grid.window(np.array([-4, -3]), np.array([3, 5]))
            np.testing.assert_array_equal(window.values, expected_window.values)
            np.testing.assert_array_equal(window.origin, expected_window.origin)
            low, high = np.array([5, 11]), np.array([40, 29])  # a crop of that window, gathered alone
            crop, expected_crop = pool.cells(particle, np.array([-4, -3]), low, high), window.view(low, high)
            np.testing.assert_array_equal(crop.values, expected_crop.values)
            np.testing.assert_array_equal(crop.origin, expected_crop.origin)


def test_resampled_particles_share_slots_until_one_writes_then_only_its_tiles_are_copied():
    pool = TilePool(PARAMS, 2)
    scan(pool, np.full(len(BEARINGS), 1.0), np.array([[0.0, 0.0, 0.0], [5.0, 5.0, 0.0]]))
    pool.resample(np.array([0, 0]))
    assert np.array_equal(pool.table[0], pool.table[1])
    held = np.count_nonzero(pool.owners)
    assert held == np.count_nonzero(pool.table[0] >= 0) and set(pool.owners[pool.owners > 0]) == {2}
    before = pool.grid(0)
    short = np.full(len(BEARINGS), 0.3)  # a scan within the tile the robot stands in: (0, 0)
    scan(pool, short, np.array([[0.4, 0.4, 0.0], [9.0, 9.0, 0.0]]))
    after = pool.grid(0)
    changed = [key for key in before.tiles if not np.array_equal(before.tiles[key], after.tiles[key])]
    assert changed == [(0, 0)]
    second = pool.grid(1)  # particle 1 wrote far away: its tiles around the origin are the ancestor's
    assert all(np.array_equal(second.tiles[key], before.tiles[key]) for key in before.tiles)
    origin = (-pool.lower[0], -pool.lower[1])  # the table's entry of tile (0, 0)
    shared = (pool.table[0] >= 0) & (pool.table[1] >= 0)
    shared[origin] = False
    held_before = [key for key in before.tiles if key != (0, 0)]
    assert shared.sum() == len(held_before)  # every other tile of the ancestor is still one slot
    assert np.array_equal(pool.table[0][shared], pool.table[1][shared])
    assert np.all(pool.owners[pool.table[0][shared]] == 2)
    assert pool.table[0][origin] != pool.table[1][origin]  # the written tile alone was copied
    assert pool.owners[pool.table[0][origin]] == 1 and pool.owners[pool.table[1][origin]] == 1


def test_widening_the_table_keeps_every_tile_at_its_key():
    pool = TilePool(PARAMS, 1)
    scan(pool, np.full(len(BEARINGS), 1.0), np.array([[0.0, 0.0, 0.0]]))
    before = pool.grid(0)
    pool.cover(np.array([-20, 3]), np.array([-19, 30]))
    after = pool.grid(0)
    assert before.tiles.keys() == after.tiles.keys()
    assert all(np.array_equal(before.tiles[key], after.tiles[key]) for key in before.tiles)
