"""Every particle's occupancy grid in one pool of tiles, shared copy-on-write.

The grid filter's particles each own a log-odds grid (``TiledGrid``'s cells and tiles: world frame,
cell ``(i, j)`` covers ``[i r, (i + 1) r) x [j r, (j + 1) r)``, tile ``(a, b)`` the cells ``a T .. a T + T
- 1`` by ``b T .. b T + T - 1``). Here they are kept together, so that one compiled call can read and
write every particle's grid (``mazeslam.gridslam.kernels``: ``match_all``, ``integrate_all``):

- ``tiles`` (capacity, T, T) float32: the log-odds of every tile any particle holds;
- ``table`` (P, A, B) int32: particle ``p``'s tile at key ``lower + (a, b)`` is ``tiles[table[p, a, b]]``,
  -1 where it has none (unknown, log-odds 0);
- ``owners`` (capacity,) int32: how many entries of ``table`` hold each slot (0: free).

A resampling copies rows of ``table``; the particles that descend from one ancestor share its slots.
A write to a slot with more than one owner first copies it to a free slot (copy on write), a write
to a slot with one owner changes it in place. Memory grows with the tiles the particles changed
since they parted, not with the particles times the map.
"""

from __future__ import annotations

import numpy as np

from mazeslam.gridslam.occupancy import GridParams, ScanRays, TiledGrid, Window

#: Slots the pool grows by at least, as a share of its capacity: the slack it may hold unused.
GROWTH = 0.1


class TilePool:
    """The log-odds grids of ``particles`` particles (see the module docstring), all empty at first.

    Attributes:
        params: the grid's cells (``GridParams``).
        tiles: (capacity, T, T) float32 log-odds; owners (capacity,) int32 the table entries per slot.
        free: (capacity,) int32, its first ``free_count[0]`` entries the free slots (a stack).
        table: (P, A, B) int32 slot of each particle's tile at key ``lower + (a, b)``, -1 none.
        lower: (2,) int64 tile key of ``table[:, 0, 0]``.
    """

    def __init__(self, params: GridParams, particles: int, capacity: int = 64):
        self.params = params
        size = params.tile_size
        self.tiles = np.zeros((capacity, size, size), dtype=np.float32)
        self.owners = np.zeros(capacity, dtype=np.int32)
        self.free = np.arange(capacity, dtype=np.int32)[::-1].copy()
        self.free_count = np.array([capacity], dtype=np.int64)
        self.table = np.full((particles, 0, 0), -1, dtype=np.int32)
        self.lower = np.zeros(2, dtype=np.int64)

    @property
    def tile_metres(self) -> float:
        return self.params.tile_size * self.params.resolution

    def cover(self, lower: np.ndarray, upper: np.ndarray) -> None:
        """Widen ``table`` so that it holds the tile keys ``lower`` .. ``upper`` (each (2,), upper
        exclusive); new entries are -1."""
        lower, upper = np.asarray(lower, dtype=np.int64), np.asarray(upper, dtype=np.int64)
        shape = np.array(self.table.shape[1:])
        if shape.all():
            lower, upper = np.minimum(lower, self.lower), np.maximum(upper, self.lower + shape)
        if np.array_equal(lower, self.lower) and np.array_equal(upper - lower, shape):
            return
        table = np.full((len(self.table), *(upper - lower)), -1, dtype=np.int32)
        a, b = self.lower - lower
        table[:, a : a + shape[0], b : b + shape[1]] = self.table
        self.table, self.lower = table, lower

    def reserve(self, slots: int) -> None:
        """Make at least ``slots`` slots free, growing the pool (by at least ``GROWTH`` of it) in
        place: the arrays are reallocated, not copied beside the old ones, so that growing never
        holds the pool twice (nothing else may hold a view of them)."""
        missing = slots - int(self.free_count[0])
        if missing <= 0:
            return
        capacity = len(self.tiles)
        added = max(missing, int(GROWTH * capacity))
        size = self.params.tile_size
        self.tiles.resize((capacity + added, size, size), refcheck=False)  # the new tiles are zero
        self.owners.resize(capacity + added, refcheck=False)
        self.free.resize(capacity + added, refcheck=False)
        count = int(self.free_count[0])
        self.free[count : count + added] = np.arange(capacity + added - 1, capacity - 1, -1, dtype=np.int32)
        self.free_count[0] = count + added

    def resample(self, indexes: np.ndarray) -> None:
        """Keep the particles ``indexes`` (P,), in that order: their tables, sharing their slots."""
        self.table = self.table[indexes]
        self._count_owners()

    def _count_owners(self) -> None:
        """``owners`` and the free stack from ``table``."""
        held = self.table[self.table >= 0]
        self.owners = np.bincount(held, minlength=len(self.tiles)).astype(np.int32)
        free = np.flatnonzero(self.owners == 0).astype(np.int32)[::-1]
        self.free[: len(free)], self.free_count[0] = free, len(free)

    def mapped(self) -> np.ndarray:
        """(P,) bool: the particle holds a tile (has mapped anything)."""
        return np.asarray((self.table >= 0).any(axis=(1, 2)))

    def integrate(self, rays: ScanRays, poses: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> None:
        """Add the scan ``rays`` to every particle's map at its pose of ``poses`` (P, 3), within its
        window of tiles ``lower`` .. ``upper`` (P, 2 each, upper exclusive; inside ``table``: see
        ``cover``), growing the pool where its free slots run out (``kernels.integrate_all``)."""
        from mazeslam.gridslam import kernels  # here, not at the top: numba loads only where the grid filter runs

        grid = self.params
        free, hits = np.ascontiguousarray(rays.free, dtype=float), np.ascontiguousarray(rays.hits, dtype=float)
        start = 0
        while True:
            start = kernels.integrate_all(
                self.tiles,
                self.owners,
                self.free,
                self.free_count,
                self.table,
                self.lower,
                grid.tile_size,
                lower,
                upper,
                lower * self.tile_metres,
                float(grid.resolution),
                free,
                hits,
                poses,
                grid.miss,
                grid.hit,
                grid.clamp,
                start,
            )
            if start == len(poses):
                return
            self.reserve(int(np.prod(upper[start] - lower[start])))

    def held_bytes(self) -> int:
        """Bytes of cells the particles hold together, each shared tile counted once."""
        return int(np.count_nonzero(self.owners)) * self.params.tile_size**2 * np.dtype(np.float32).itemsize

    def grid(self, particle: int) -> TiledGrid:
        """``particle``'s map as a ``TiledGrid`` of its own (copies of its tiles)."""
        a, b = np.nonzero(self.table[particle] >= 0)
        slots = self.table[particle, a, b]
        keys = zip((a + self.lower[0]).tolist(), (b + self.lower[1]).tolist())
        return TiledGrid(self.params, {key: self.tiles[slot].copy() for key, slot in zip(keys, slots)})

    def window(self, particle: int, lower: np.ndarray, upper: np.ndarray) -> Window:
        """``particle``'s cells of tiles ``lower`` .. ``upper`` (each (2,), upper exclusive) as one
        dense array (a copy), as ``TiledGrid.window`` gives them (tiles beyond ``table``: unknown)."""
        from mazeslam.gridslam import kernels  # here, not at the top: numba loads only where the grid filter runs

        lower, upper = np.asarray(lower, dtype=np.int64), np.asarray(upper, dtype=np.int64)
        size = self.params.tile_size
        values = np.empty(((upper[0] - lower[0]) * size, (upper[1] - lower[1]) * size), dtype=np.float32)
        kernels.gather(self.tiles, self.table[particle], self.lower, size, lower * size, values)
        return Window(values, lower * self.tile_metres, self.params.resolution, lower)

    def cells(self, particle: int, lower: np.ndarray, low: np.ndarray, high: np.ndarray) -> Window:
        """``particle``'s cells ``low`` .. ``high`` (each (2,), high exclusive) of the window whose
        cell [0, 0] is tile ``lower``'s first (2,): what ``window(particle, lower, ...).view(low,
        high)`` gives, without gathering the rest of the window."""
        from mazeslam.gridslam import kernels  # here, not at the top: numba loads only where the grid filter runs

        lower, low, high = (np.asarray(value, dtype=np.int64) for value in (lower, low, high))
        first, _, origin = self.crops(lower, low, high)
        values = np.empty(tuple(high - low), dtype=np.float32)
        kernels.gather(self.tiles, self.table[particle], self.lower, self.params.tile_size, first, values)
        return Window(values, origin, self.params.resolution, lower)

    def crops(self, lower: np.ndarray, low: np.ndarray, high: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The cells ``low`` .. ``high`` (..., 2 each, high exclusive) of windows whose cell [0, 0] is
        tile ``lower``'s first (..., 2) as global cells (first, end: (..., 2) each) and the world
        position (..., 2) of their first cell's lower corner, m (as ``Window.view`` places it)."""
        size = self.params.tile_size
        return lower * size + low, lower * size + high, lower * self.tile_metres + low * self.params.resolution
