"""A grid map in a figure: a building-scale map keeps its occupied cells; occupancy.png is a readable figure."""

import matplotlib.image
import numpy as np

from mazeslam.data.map_io import FREE, OCCUPIED, UNKNOWN, OccupancyMap
from mazeslam.viz.grid_figure import darkest_of_blocks, plot_occupancy


def test_an_occupied_cell_survives_the_shrinking_to_the_figures_pixels():
    image = np.full((31, 2400), 254, dtype=np.uint8)  # free, 5 cm cells over 120 m
    image[30, 2399] = 0  # one occupied cell, in the last (partial) row of blocks
    image[3, 5] = 205  # an unknown one
    shrunk = darkest_of_blocks(image, 800)
    assert shrunk.shape == (11, 800)  # blocks of 3 x 3 cells, the last row padded
    assert shrunk[10, 799] == 0 and shrunk[1, 1] == 205 and (shrunk == 0).sum() == 1
    np.testing.assert_array_equal(darkest_of_blocks(image[:, :800], 800), image[:, :800])  # small maps: as they are


def dark_pixels(path) -> int:
    """How many pixels of the image ``path`` are black (every channel below 0.1)."""
    return int((matplotlib.image.imread(path)[..., :3].max(axis=2) < 0.1).sum())


def test_occupancy_png_is_a_figure_of_the_map_at_a_readable_size(tmp_path):
    states = np.full((68, 68), UNKNOWN, dtype=np.int8)  # a course map: 68 x 68 cells of 1 cm
    states[10:60, 10:60] = FREE
    without_wall = plot_occupancy(tmp_path / "free.png", OccupancyMap(states.copy(), 0.01, np.zeros(3)), "log1")
    states[10:60, 10] = OCCUPIED  # a wall of 50 cells
    path = plot_occupancy(tmp_path / "occupancy.png", OccupancyMap(states, 0.01, np.zeros(3)), "log1")
    height, width, _ = matplotlib.image.imread(path).shape
    assert min(height, width) >= 600  # not one pixel per cell
    # The same figure but for the wall: its 50 cells add far more than 50 black pixels (drawn large).
    assert dark_pixels(path) - dark_pixels(without_wall) > 20 * 50
