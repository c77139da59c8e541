"""The grid filter's scan step for every particle in one compiled call each (numba, ``cache=True``).

The particles' maps live in a ``TilePool`` (``mazeslam.gridslam.tile_pool``: ``tiles`` (capacity, T,
T) float32 log-odds, ``table`` (P, A, B) int32 each particle's slot per tile key from ``lower``
(2,), -1 none). Cells are global: cell ``(i, j)`` is in tile ``(i // T, j // T)`` at ``(i % T, j %
T)``. The steps, in the order a scan uses them:

1. ``match_all``: for each particle, its map's cells around the scan's end points gathered into one
   array (``gather``), the scan matched there and, where the match is accepted, the proposal's
   stencil scored around it (``mazeslam.gridslam.kernels``: ``match``, ``proposal``).
2. ``integrate_all``: each particle's scan added to its own tiles at its new pose, a tile shared
   with other particles copied to a free slot first (copy on write).

Imported only where the grid filter runs, as ``kernels`` is.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from mazeslam.gridslam import kernels

#: ``match_all``'s outcome per particle: nothing to match (no map, under 3 points or no occupied
#: cell near them), the match accepted (the proposal is scored), or the match failed (the caller
#: rescues it).
NOTHING, ACCEPTED, FAILED = 0, 1, 2


@njit(cache=True)
def gather(tiles, table, lower, tile_size, low, out):
    """Fill ``out`` (X, Y) float32 with one particle's log-odds of the cells ``low`` .. ``low + (X,
    Y)`` (global cells, (2,)): ``table`` (A, B) its slots from tile key ``lower`` (2,), -1 or outside
    the table unknown (0)."""
    size_x, size_y = out.shape
    for i in range(size_x):
        row = low[0] + i
        a, cell_a = row // tile_size - lower[0], row % tile_size
        j = 0
        while j < size_y:
            column = low[1] + j
            b, cell_b = column // tile_size - lower[1], column % tile_size
            run = min(tile_size - cell_b, size_y - j)  # the cells of this row within one tile
            slot = table[a, b] if 0 <= a < table.shape[0] and 0 <= b < table.shape[1] else -1
            if slot < 0:
                out[i, j : j + run] = 0.0
            else:
                out[i, j : j + run] = tiles[slot, cell_a, cell_b : cell_b + run]
            j += run


@njit(cache=True)
def match_all(
    tiles,
    table,
    lower,
    tile_size,
    resolution,
    mapped,
    crop_low,
    crop_high,
    crop_origins,
    points,
    predicted,
    information,
    settings,
    within,
    min_overlap,
    steps,
    sigma,
    scale,
    floor,
    threshold,
):
    """Each particle's scan match and proposal against its own map.

    Args:
        tiles, table, lower, tile_size: the pool (module docstring); resolution: cell size, m.
        mapped: (P,) bool the particle holds a tile.
        crop_low, crop_high: (P, 2) int64 the global cells (high exclusive) of each particle's
            likelihood field, whose cell [0, 0]'s corner is at ``crop_origins`` (P, 2), m.
        points: (N, 2) the end points to match, robot frame, m.
        predicted: (P, 3) each particle's predicted pose (the prior's mean, world frame).
        information: (3, 3) the prior's information; settings, within: ``kernels.match``'s.
        min_overlap: the share of points near a wall at which the match is accepted.
        steps, sigma, scale, floor: ``kernels.proposal``'s; threshold: log-odds of an occupied cell.

    Returns:
        status (P,) int8 (``NOTHING``, ``ACCEPTED``, ``FAILED``), modes (P, 3) the matches, and where
        accepted the proposal's ``log eta`` (P,), mean (P, 3) and covariance (P, 3, 3).
    """
    count = predicted.shape[0]
    status = np.zeros(count, dtype=np.int8)
    modes, log_etas = np.zeros((count, 3)), np.zeros(count)
    means, covariances = np.zeros((count, 3)), np.zeros((count, 3, 3))
    largest = 0
    for p in range(count):
        largest = max(largest, (crop_high[p, 0] - crop_low[p, 0]) * (crop_high[p, 1] - crop_low[p, 1]))
    scratch = np.empty(largest, dtype=np.float32)
    memo, stamps = np.empty(largest, dtype=np.float32), np.zeros(largest, dtype=np.int64)
    for p in range(count):
        if not mapped[p] or points.shape[0] < 3:
            continue
        size_x, size_y = crop_high[p, 0] - crop_low[p, 0], crop_high[p, 1] - crop_low[p, 1]
        values = scratch[: size_x * size_y].reshape((size_x, size_y))
        gather(tiles, table[p], lower, tile_size, crop_low[p], values)
        if not kernels.any_occupied(values, threshold):
            continue
        blocks = np.full((-(-size_x // kernels.BLOCK), -(-size_y // kernels.BLOCK)), -1, dtype=np.int8)
        field = (values, threshold, blocks, memo, stamps, p + 1, crop_origins[p], resolution)
        modes[p], share = kernels.match(field, points, predicted[p], information, settings, within)
        if share < min_overlap:
            status[p] = FAILED
            continue
        status[p] = ACCEPTED
        log_etas[p], means[p], covariances[p] = kernels.proposal(
            field, points, modes[p], predicted[p], information, steps, sigma, scale, floor
        )
    return status, modes, log_etas, means, covariances


@njit(cache=True)
def _writable_slot(tiles, owners, free, free_count, table, p, a, b):
    """The slot particle ``p`` may write its tile ``(a, b)`` of ``table`` in: its own, or, where it
    has none, a free slot zeroed, or, where others share it, a free slot holding a copy."""
    slot = table[p, a, b]
    if slot >= 0 and owners[slot] == 1:
        return slot
    free_count[0] -= 1
    taken = free[free_count[0]]
    if slot < 0:
        tiles[taken] = 0.0
    else:
        tiles[taken] = tiles[slot]
        owners[slot] -= 1
    owners[taken] = 1
    table[p, a, b] = taken
    return taken


@njit(cache=True)
def integrate_all(
    tiles,
    owners,
    free,
    free_count,
    table,
    lower,
    tile_size,
    window_lower,
    window_upper,
    window_origins,
    resolution,
    free_samples,
    hits,
    poses,
    miss,
    hit,
    clamp,
    start,
):
    """Add the scan to each particle's map at its pose, from particle ``start`` on.

    Each cell a sample of ``free_samples`` (F, 2) (robot frame, m) falls in gets ``miss`` once,
    each cell a point of ``hits`` (H, 2) falls in gets ``hit`` once and no miss, both clamped to
    [-clamp, clamp] (``kernels.integrate``), within the particle's window: tiles ``window_lower`` ..
    ``window_upper`` (P, 2, upper exclusive), cell [0, 0]'s corner at ``window_origins`` (P, 2) m;
    samples outside it are left out. ``poses`` (P, 3) world frame. The pool's ``tiles``, ``owners``,
    ``free`` stack (``free_count`` (1,)) and ``table`` change in place (``_writable_slot``).

    Returns the particle it stopped before: ``P`` when done, less when fewer slots are free than
    that particle's window has tiles (the caller grows the pool and calls again from there).
    """
    count = poses.shape[0]
    widest_x, widest_y = 0, 0
    for p in range(count):
        widest_x = max(widest_x, (window_upper[p, 0] - window_lower[p, 0]) * tile_size)
        widest_y = max(widest_y, (window_upper[p, 1] - window_lower[p, 1]) * tile_size)
    marks = np.zeros(widest_x * widest_y, dtype=np.uint8)  # 1: a beam crosses the cell, 2: one ends in it
    rows = np.empty(free_samples.shape[0] + hits.shape[0], dtype=np.int32)
    columns = np.empty_like(rows)
    tile_of = np.arange(max(widest_x, widest_y)) // tile_size  # a window's row or column -> its tile
    low, high = np.float32(-clamp), np.float32(clamp)
    for p in range(start, count):
        tiles_x, tiles_y = window_upper[p, 0] - window_lower[p, 0], window_upper[p, 1] - window_lower[p, 1]
        if free_count[0] < tiles_x * tiles_y:
            return p
        window_marks = marks[: tiles_x * tile_size * tiles_y * tile_size].reshape((tiles_x * tile_size, -1))
        x0, y0, cos_t, sin_t = poses[p, 0], poses[p, 1], math.cos(poses[p, 2]), math.sin(poses[p, 2])
        placed = (window_origins[p], resolution, x0, y0, cos_t, sin_t)
        marked = kernels.mark(free_samples, 1, window_marks, rows, columns, 0, *placed)
        marked = kernels.mark(hits, 2, window_marks, rows, columns, marked, *placed)
        offset_a, offset_b = window_lower[p, 0] - lower[0], window_lower[p, 1] - lower[1]
        for k in range(marked):
            i, j = rows[k], columns[k]
            change = np.float32(hit) if window_marks[i, j] == 2 else np.float32(miss)
            window_marks[i, j] = 0  # clean for the next particle
            a, b = offset_a + tile_of[i], offset_b + tile_of[j]
            slot = table[p, a, b]
            if slot < 0 or owners[slot] != 1:  # once a tile: a compiled call costs more than a cell
                slot = _writable_slot(tiles, owners, free, free_count, table, p, a, b)
            cell_a, cell_b = i - tile_of[i] * tile_size, j - tile_of[j] * tile_size
            tiles[slot, cell_a, cell_b] = min(max(tiles[slot, cell_a, cell_b] + change, low), high)
    return count
