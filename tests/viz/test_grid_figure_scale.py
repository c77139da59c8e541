"""Issue 35: a building-scale grid map keeps its occupied cells in the figure."""

import numpy as np

from mazeslam.viz.grid_figure import darkest_of_blocks


def test_an_occupied_cell_survives_the_shrinking_to_the_figures_pixels():
    image = np.full((31, 2400), 254, dtype=np.uint8)  # free, 5 cm cells over 120 m
    image[30, 2399] = 0  # one occupied cell, in the last (partial) row of blocks
    image[3, 5] = 205  # an unknown one
    shrunk = darkest_of_blocks(image, 800)
    assert shrunk.shape == (11, 800)  # blocks of 3 x 3 cells, the last row padded
    assert shrunk[10, 799] == 0 and shrunk[1, 1] == 205 and (shrunk == 0).sum() == 1
    np.testing.assert_array_equal(darkest_of_blocks(image[:, :800], 800), image[:, :800])  # small maps: as they are
