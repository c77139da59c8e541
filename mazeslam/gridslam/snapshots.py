"""Frames of a grid filter run for an animation (``mazeslam.viz.grid_animation``).

While the filter runs, ``GridSnapshot``s keep what a frame needs (``snapshot``): the best
particle's cell states, shrunk to at most ``MAX_CELLS`` on the longer side (a block is occupied if
any of its cells is, else free if any is, else unknown, so one-cell walls stay visible), and the
particles.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mazeslam.data.map_io import FREE, OCCUPIED, UNKNOWN, OccupancyMap
from mazeslam.gridslam.occupancy import TiledGrid, grid_states

#: The longer side of a snapshot's map, cells (a 100 m building at 0.05 m is shrunk 5 times).
MAX_CELLS = 400


@dataclass(frozen=True)
class GridSnapshot:
    """One frame: the scan's index, the best particle's map (shrunk) and the particles (P, 3)."""

    index: int
    occupancy: OccupancyMap
    particles: np.ndarray


def shrink(occupancy: OccupancyMap, max_cells: int = MAX_CELLS) -> OccupancyMap:
    """``occupancy`` shrunk by a whole factor to at most ``max_cells`` cells on its longer side
    (occupied if any cell of a block is, else free if any is, else unknown)."""
    states = occupancy.states
    factor = max(1, int(np.ceil(max(states.shape, default=0) / max_cells)))
    if factor == 1:
        return occupancy
    rows, columns = -(-states.shape[0] // factor), -(-states.shape[1] // factor)
    padded = np.full((rows * factor, columns * factor), UNKNOWN, dtype=np.int8)
    padded[: states.shape[0], : states.shape[1]] = states
    blocks = padded.reshape(rows, factor, columns, factor)
    shrunk = np.full((rows, columns), UNKNOWN, dtype=np.int8)
    shrunk[(blocks == FREE).any(axis=(1, 3))] = FREE
    shrunk[(blocks == OCCUPIED).any(axis=(1, 3))] = OCCUPIED
    return OccupancyMap(shrunk, occupancy.resolution * factor, occupancy.origin)


def snapshot(index: int, grid: TiledGrid, particles: np.ndarray) -> GridSnapshot:
    """A frame of scan ``index``: ``grid`` (the best particle's map) shrunk, a copy of ``particles``."""
    return GridSnapshot(index, shrink(grid_states(grid)), np.array(particles, dtype=float))
