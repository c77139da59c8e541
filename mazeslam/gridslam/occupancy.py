"""Occupancy grid in log-odds, tiled so that particles share what they have in common.

World frame, metres. Cell ``(i, j)`` covers ``[i r, (i + 1) r) x [j r, (j + 1) r)`` for the
resolution ``r``; arrays of cells are indexed ``[i, j]`` (x first). Cells are grouped in square
tiles of ``tile_size`` cells; tile ``(a, b)`` holds cells ``a T .. a T + T - 1`` by ``b T .. b T + T - 1``.

Tiles are immutable: a write replaces the tiles it changes by new arrays, so ``copy`` (what a
resampling does for each surviving particle) copies only the dictionary of tile references, never
a cell. Particles that descend from one ancestor share every tile neither has written since, and
memory grows with the tiles they changed, not with the particles times the map.

A log-odds value ``l`` is the probability ``1 / (1 + exp(-l))`` that a cell is occupied: 0 is
unknown, positive occupied, negative free.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from mazeslam.core.config import require
from mazeslam.data.map_io import FREE, OCCUPIED, UNKNOWN, OccupancyMap

TileKey = tuple[int, int]


@dataclass(frozen=True)
class GridParams:
    """Cells and how one scan changes them.

    Attributes:
        resolution: cell size, m.
        tile_size: cells along a tile's side.
        hit: log-odds added to the cell a beam ends in.
        miss: log-odds added to a cell a beam crosses (negative).
        clamp: log-odds stay within [-clamp, clamp], so that a map can change its mind.
        min_range: returns nearer than this are left out as no return, m (a sensor's untrusted
            near span: the course robot's camera trusts 0.05-0.4 m).
        max_range: beams update the map up to this range, m; a longer beam clears the cells up to
            it and marks nothing occupied.
        trace_step: distance between the samples along a beam that mark cells free, in cells.
        clear_no_return: a beam with no return (range 0) clears the cells up to the sensor's
            maximum range (at most ``max_range``; ``scan_rays``), where the sensor's range is known,
            as gmapping's maxUrange does. Off by default and in configs/carmen.toml: indoors a SICK also
            reads nothing from glass or a dark surface within range (on the CARMEN logs it made no
            log clearly better and left 3 of 10 orebro seeds above 1 m: docs/grid.md, step 4), and the course
            robot's camera reads 0 for a wall inside its blind disc or one it missed.
    """

    resolution: float = 0.05
    tile_size: int = 64
    hit: float = 0.85
    miss: float = -0.4
    clamp: float = 5.0
    min_range: float = 0.0
    max_range: float = 20.0
    trace_step: float = 0.8
    clear_no_return: bool = False

    def __post_init__(self):
        require(self.resolution > 0 and self.max_range > 0, "resolution and max_range must be positive (m)")
        require(0 <= self.min_range < self.max_range, "need 0 <= min_range < max_range (m)")
        require(self.tile_size >= 4, "tile_size must be at least 4 cells")
        require(self.hit > 0 > self.miss and self.clamp > 0, "need hit > 0 > miss and clamp > 0 (log-odds)")
        require(0 < self.trace_step <= 1, "trace_step must be in (0, 1] cells")


class TiledGrid:
    """A log-odds grid stored as immutable tiles (see the module docstring).

    Attributes:
        tiles: tile key ``(a, b)`` -> float32 array (T, T) of log-odds; absent tiles are unknown (0).
    """

    def __init__(self, params: GridParams, tiles: dict[TileKey, np.ndarray] | None = None):
        self.params = params
        self.tiles = {} if tiles is None else tiles

    def copy(self) -> TiledGrid:
        """A grid sharing every tile with this one: copies references only."""
        return TiledGrid(self.params, dict(self.tiles))

    @property
    def tile_metres(self) -> float:
        return self.params.tile_size * self.params.resolution

    def tile_range(self, points: np.ndarray, margin: float) -> tuple[np.ndarray, np.ndarray]:
        """The tiles covering ``points`` (..., N, 2) (world, m) widened by ``margin`` m (``tile_range``)."""
        return tile_range(points, margin, self.tile_metres)

    def window(self, lower: np.ndarray, upper: np.ndarray) -> Window:
        """The cells of tiles ``lower`` .. ``upper`` (exclusive) as one dense array to read and edit."""
        size = self.params.tile_size
        values = np.zeros(((upper[0] - lower[0]) * size, (upper[1] - lower[1]) * size), dtype=np.float32)
        for a, b in itertools.product(range(lower[0], upper[0]), range(lower[1], upper[1])):  # the window's tiles,
            tile = self.tiles.get((a, b))  # not the whole map's: the cost stays flat as the map grows
            if tile is not None:
                i, j = (a - lower[0]) * size, (b - lower[1]) * size
                values[i : i + size, j : j + size] = tile
        return Window(values, lower * self.tile_metres, self.params.resolution, lower)

    def store(self, window: Window, changed: np.ndarray) -> None:
        """Replace the tiles of ``window`` flagged in ``changed`` (bool (tiles x, tiles y), what
        ``integrate_scan`` returns) by new tiles copied from it; other tiles keep their (possibly
        shared) arrays."""
        size = self.params.tile_size
        for a, b in zip(*np.nonzero(changed)):
            block = window.values[a * size : (a + 1) * size, b * size : (b + 1) * size]
            self.tiles[(int(window.lower_tile[0] + a), int(window.lower_tile[1] + b))] = block.copy()

    def dense(self) -> tuple[np.ndarray, np.ndarray]:
        """The whole map as one array (X, Y) of log-odds and the world position (2,) of its cell
        (0, 0)'s lower corner, m. An empty grid gives an empty array at the origin."""
        if not self.tiles:
            return np.zeros((0, 0), dtype=np.float32), np.zeros(2)
        keys = np.array(list(self.tiles))
        window = self.window(keys.min(axis=0), keys.max(axis=0) + 1)
        return window.values, window.origin


def tile_range(points: np.ndarray, margin: float, tile_metres: float) -> tuple[np.ndarray, np.ndarray]:
    """The tiles (lower (..., 2), upper (..., 2), upper exclusive) of side ``tile_metres`` (m)
    covering ``points`` (..., N, 2) (world, m) widened by ``margin`` metres (one range per leading
    index)."""
    lower = np.floor((points.min(axis=-2) - margin) / tile_metres).astype(int)
    upper = np.floor((points.max(axis=-2) + margin) / tile_metres).astype(int) + 1
    return lower, upper


@dataclass
class Window:
    """A dense block of a grid's cells.

    Attributes:
        values: (X, Y) float32 log-odds, indexed [i, j] with i along world x.
        origin: (2,) world position of cell [0, 0]'s lower corner, m.
        resolution: cell size, m.
        lower_tile: (2,) the tile of cell [0, 0].
    """

    values: np.ndarray
    origin: np.ndarray
    resolution: float
    lower_tile: np.ndarray

    def crop(self, points: np.ndarray, margin: float) -> Window:
        """A view of the cells around ``points`` (N, 2) (world, m) widened by ``margin`` m, within
        this window; for reading only (``TiledGrid.store`` takes whole windows)."""
        box = np.stack([points.min(axis=0), points.max(axis=0)])
        return self.view(*crop_cells(box, margin, self.origin, np.array(self.values.shape), self.resolution))

    def view(self, low: np.ndarray, high: np.ndarray) -> Window:
        """The cells ``low`` .. ``high`` (each (2,), high exclusive) of this window, in place."""
        return Window(
            self.values[low[0] : high[0], low[1] : high[1]],
            self.origin + low * self.resolution,
            self.resolution,
            self.lower_tile,
        )


def crop_cells(
    box: np.ndarray, margin: float, origin: np.ndarray, shape: np.ndarray, resolution: float
) -> tuple[np.ndarray, np.ndarray]:
    """The cells (low (..., 2), high (..., 2), high exclusive) of windows of ``shape`` (..., 2) cells
    whose cell [0, 0] lies at ``origin`` (..., 2) (m) that cover ``box`` (..., 2, 2) (lower and upper
    corner, world, m) widened by ``margin`` m: within the window, at least 2 cells a side."""
    low = np.floor((box[..., 0, :] - margin - origin) / resolution).astype(int)
    high = np.ceil((box[..., 1, :] + margin - origin) / resolution).astype(int)
    low = np.clip(low, 0, shape - 2)
    high = np.clip(high, low + 2, shape)
    return low, high


@dataclass(frozen=True)
class ScanRays:
    """One scan as the map update needs it, in the robot frame (the same for every particle).

    Attributes:
        free: (F, 2) samples along the beams, from the sensor to just before each end, m.
        hits: (H, 2) the ends of the beams that returned within ``max_range``, m.
        reach: (B, 2) the farthest point each beam updates (its end, or its cut at ``max_range`` or
            at the sensor's maximum range for a beam with no return).
    """

    free: np.ndarray
    hits: np.ndarray
    reach: np.ndarray


def scan_rays(
    ranges: np.ndarray, bearings: np.ndarray, mount: np.ndarray, params: GridParams, sensor_max_range: float = 0.0
) -> ScanRays:
    """The samples of a scan: ``ranges`` (N,) m, ``bearings`` (N,) rad in the robot frame, the
    sensor at ``mount`` (2,) in the robot frame.

    A beam with no return (range 0) saw nothing nearer than the sensor's maximum range: with
    ``sensor_max_range`` (m, > 0) known it clears the cells up to that range (at most
    ``params.max_range``) and marks none occupied, as a return beyond ``params.max_range`` does
    (gmapping's maxUrange); with 0 (unknown) it is left out. Returns nearer than
    ``params.min_range`` are always left out."""
    returned = (ranges > 0) & (ranges >= params.min_range)
    empty = (ranges == 0) & (sensor_max_range > 0)
    keep = returned | empty
    ranges, bearings, empty = ranges[keep], bearings[keep], empty[keep]
    hit = ~empty & (ranges <= params.max_range)
    reached = np.where(empty, min(sensor_max_range, params.max_range), np.minimum(ranges, params.max_range))
    length = reached - np.where(hit, 0.5 * params.resolution, 0.0)
    step = params.trace_step * params.resolution
    counts = np.maximum(np.ceil(length / step).astype(int), 0)
    beam = np.repeat(np.arange(len(ranges)), counts)
    distance = (np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)) * step
    directions = np.column_stack([np.cos(bearings), np.sin(bearings)])
    free = mount + distance[:, None] * directions[beam]
    reach = mount + reached[:, None] * directions
    return ScanRays(free, reach[hit], reach)


def integrate_scan(window: Window, rays: ScanRays, pose: np.ndarray, params: GridParams) -> np.ndarray:
    """Add one scan taken at robot ``pose`` (3,) to ``window`` in place: each cell a beam crosses
    gets ``miss`` once, each cell a beam ends in ``hit`` once (and no miss), clamped. Samples
    outside the window are left out. Returns the tiles changed: bool (tiles x, tiles y) of the
    window's, as ``TiledGrid.store`` takes them (``mazeslam.gridslam.kernels.integrate``)."""
    from mazeslam.gridslam import kernels  # here, not at the top: numba loads only where the grid filter runs

    cos_t, sin_t = np.cos(pose[2]), np.sin(pose[2])
    return kernels.integrate(
        window.values,
        np.asarray(window.origin, dtype=float),
        float(window.resolution),
        np.ascontiguousarray(rays.free, dtype=float),
        np.ascontiguousarray(rays.hits, dtype=float),
        float(pose[0]),
        float(pose[1]),
        float(cos_t),
        float(sin_t),
        params.miss,
        params.hit,
        params.clamp,
        params.tile_size,
    )


def grid_states(grid: TiledGrid, occupied_above: float = 0.0, free_below: float = 0.0) -> OccupancyMap:
    """The cell states of ``grid``: occupied where the log-odds exceed ``occupied_above``, free
    where they are below ``free_below``, unknown elsewhere (never-seen cells are 0)."""
    log_odds, origin = grid.dense()
    states = np.full(log_odds.shape, UNKNOWN, dtype=np.int8)
    states[log_odds < free_below] = FREE
    states[log_odds > occupied_above] = OCCUPIED
    return OccupancyMap(states, grid.params.resolution, np.r_[origin, 0.0])
