"""The grid animation's map snapshots: shrunk so that walls one cell thick stay visible."""

import numpy as np
import pytest

from mazeslam.data.map_io import FREE, OCCUPIED, UNKNOWN, OccupancyMap
from mazeslam.gridslam.snapshots import shrink


def test_shrink_keeps_one_cell_walls_and_free_space():
    states = np.full((10, 7), UNKNOWN, dtype=np.int8)
    states[:4, :] = FREE
    states[6, 5] = OCCUPIED  # a wall one cell thick
    shrunk = shrink(OccupancyMap(states, 0.05, np.array([1.0, 2.0, 0.0])), max_cells=4)
    # factor ceil(10 / 4) = 3: blocks of 3 x 3 cells, (4, 3) of them (padded with unknown)
    assert shrunk.states.shape == (4, 3) and shrunk.resolution == pytest.approx(0.15)
    np.testing.assert_array_equal(shrunk.origin, [1.0, 2.0, 0.0])
    expected = np.full((4, 3), UNKNOWN)
    expected[:2, :] = FREE  # cells 0-3 are free: blocks 0 and 1 along x
    expected[2, 1] = OCCUPIED  # cell (6, 5) is in block (2, 1)
    np.testing.assert_array_equal(shrunk.states, expected)


def test_a_small_map_is_kept_as_it_is():
    occupancy = OccupancyMap(np.zeros((5, 5), dtype=np.int8), 0.05, np.zeros(3))
    assert shrink(occupancy, max_cells=5) is occupancy
