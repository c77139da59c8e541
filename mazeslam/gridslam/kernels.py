"""Compiled kernels of the grid filter (numba, ``cache=True``: compiled once per machine and kept on
disk beside this module, or in numba's user cache where that is not writable).

Imported only where the grid filter runs (``mazeslam.gridslam.matching`` and ``.occupancy`` import
it inside their functions): numba takes about 0.15 s to import, and a config that merely names the
grid's settings should not pay it.

Cells: a window's log-odds ``values`` (X, Y) float32 are indexed ``[i, j]``, i along world x; cell
``[i, j]`` covers ``origin + [i, i + 1) r x [j, j + 1) r`` for the resolution ``r`` (m). A cell is
occupied where its log-odds exceed ``threshold``.

The kernels, in the order a scan uses them:

0. ``bounds``: the box each particle's scan covers, for the map windows to read.
1. ``any_occupied``: whether the window has an occupied cell to match against at all.
2. ``lookup``: the distance (m) at world points, bilinear between the four nearest cell centres,
   and its gradient (the likelihood field). A cell's distance is the exact Euclidean distance from
   its centre to the nearest occupied cell's centre, up to the field's reach, searched the first
   time a lookup reads it (``_search``: rings of cells around it, then the occupied cells of rings
   of ``BLOCK`` x ``BLOCK`` blocks, nearest ring first, none beyond the reach). The same
   values as a distance transform of the whole window (``cv2.distanceTransform``,
   ``DIST_MASK_PRECISE``) clipped at the reach, for the few thousand cells a scan match reads
   instead of every cell of the window.
3. ``match``: ``refine`` (iteratively reweighted Gauss-Newton of a pose on that distance plus a
   Gaussian prior, ``mazeslam.gridslam.matching.refine_pose``), then ``overlap`` (the share of
   points near a wall) at the result.
4. ``proposal``: the stencil's scores (``objective``) around the match, and their moments.
5. ``integrate``: a scan's free samples and hits added to a window (``integrate_scan``).

Steps 1-5 for every particle at once, its map in a ``TilePool`` (``mazeslam.gridslam.tile_pool``:
``tiles`` (capacity, T, T) float32 log-odds, ``table`` (P, A, B) int32 each particle's slot per
tile key from ``lower`` (2,), -1 none; global cell ``(i, j)`` is in tile ``(i // T, j // T)`` at
``(i % T, j % T)``):

6. ``match_all``: for each particle, its map's cells around the scan's end points gathered into one
   array (``gather``), ``match`` there and, where the match is accepted, ``proposal``.
7. ``integrate_all``: each particle's scan added to its own tiles at its new pose, a tile shared
   with other particles copied to a free slot first (copy on write).

One module for all of them: numba renews the cached code of a compiled function only when its own
file changes, so a kernel that calls another must live in the same file (else an edit to the
callee leaves the caller's cached copy of it stale).

The distance kernels take the window and its memo as one tuple, ``field``: ``(values, threshold,
blocks, memo, stamps, stamp, origin, resolution, reach)``, the log-odds (X, Y) float32 and the
occupied threshold, the blocks' occupied cells (``empty_blocks``), the memo's distances (float32)
and stamps (int32, each >= X * Y, ``lookup``) and this window's stamp, the origin (2,) m, the
resolution m and the distance (cells) at which the searches end
(``mazeslam.gridslam.matching.LikelihoodField.kernel_field``, ``field_reach``).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

#: Side of the blocks the distance search reads by their lists of occupied cells, cells (at most
#: 181: a block's offsets are int16).
BLOCK = 8
#: Rings of single cells searched around a cell before the search turns to blocks.
NEAR_RINGS = 4


@njit(cache=True)
def bounds(starts, points, with_starts):
    """Per particle, the box (P, 2, 2) (lower and upper corner, world, m) of ``points`` (N, 2)
    (robot frame) placed at each of its ``starts`` (P, K, 3), and of the starts' own positions with
    ``with_starts``."""
    count = starts.shape[0]
    boxes = np.empty((count, 2, 2))
    for p in range(count):
        low_x = low_y = math.inf
        high_x = high_y = -math.inf
        for k in range(starts.shape[1]):
            x0, y0 = starts[p, k, 0], starts[p, k, 1]
            cos_t, sin_t = math.cos(starts[p, k, 2]), math.sin(starts[p, k, 2])
            if with_starts:
                low_x, high_x, low_y, high_y = min(low_x, x0), max(high_x, x0), min(low_y, y0), max(high_y, y0)
            for n in range(points.shape[0]):
                x = x0 + cos_t * points[n, 0] - sin_t * points[n, 1]
                y = y0 + sin_t * points[n, 0] + cos_t * points[n, 1]
                low_x, high_x, low_y, high_y = min(low_x, x), max(high_x, x), min(low_y, y), max(high_y, y)
        boxes[p, 0, 0], boxes[p, 0, 1], boxes[p, 1, 0], boxes[p, 1, 1] = low_x, low_y, high_x, high_y
    return boxes


@njit(cache=True)
def any_occupied(values: np.ndarray, threshold: float) -> bool:
    """Whether a cell of ``values`` (X, Y) is above ``threshold`` (stops at the first)."""
    for i in range(values.shape[0]):
        for j in range(values.shape[1]):
            if values[i, j] > threshold:
                return True
    return False


@njit(cache=True)
def empty_blocks(size_x, size_y):
    """The block lists of a window of (size_x, size_y) cells, none made yet: (ceil(X / BLOCK),
    ceil(Y / BLOCK), 1 + BLOCK^2) int16, entry 0 of each block -1 (``_block_search``)."""
    blocks = np.empty((-(-size_x // BLOCK), -(-size_y // BLOCK), 1 + BLOCK * BLOCK), dtype=np.int16)
    blocks[:, :, 0] = -1
    return blocks


@njit(cache=True)
def _list_block(values, threshold, blocks, block_a, block_b, low_a, high_a, low_b, high_b):
    """List the occupied cells of rows low_a..high_a, columns low_b..high_b (inclusive) in
    ``blocks[block_a, block_b]``: their count at 0, then each as its offset ``(a - low_a) BLOCK +
    (b - low_b)``."""
    count = 0
    for a in range(low_a, high_a + 1):
        for b in range(low_b, high_b + 1):
            if values[a, b] > threshold:
                count += 1
                blocks[block_a, block_b, count] = (a - low_a) * BLOCK + (b - low_b)
    blocks[block_a, block_b, 0] = count


@njit(cache=True)
def _ring_search(values, threshold, i, j, rings, best):
    """The least squared distance (cells) below ``best`` from cell (i, j) to an occupied cell at a
    Chebyshev distance of at most ``rings`` cells (``best`` where there is none). Ring ``r`` holds
    the cells at Chebyshev distance r, none nearer than r: the search stops once r^2 >= best."""
    size_x, size_y = values.shape
    for ring in range(rings + 1):
        if ring * ring >= best:
            break
        for a in range(max(i - ring, 0), min(i + ring, size_x - 1) + 1):
            if a == i - ring or a == i + ring:  # the ring's top and bottom rows, whole
                for b in range(max(j - ring, 0), min(j + ring, size_y - 1) + 1):
                    best = _closer(values[a, b], threshold, i, j, a, b, best)
            else:  # its sides, two cells a row
                if j - ring >= 0:
                    best = _closer(values[a, j - ring], threshold, i, j, a, j - ring, best)
                if j + ring < size_y:
                    best = _closer(values[a, j + ring], threshold, i, j, a, j + ring, best)
    return best


@njit(cache=True)
def _closer(value, threshold, i, j, a, b, best):
    """``best`` or, if cell (a, b) (log-odds ``value``) is occupied and nearer to (i, j), its
    squared distance (cells). Scalars only, so that it compiles inline into the search loops."""
    if value > threshold:
        squared = (a - i) ** 2 + (b - j) ** 2
        if squared < best:
            return float(squared)
    return best


@njit(cache=True)
def _block_search(values, threshold, blocks, i, j, best):
    """The least squared distance (cells) below ``best`` from cell (i, j) to an occupied cell, over
    the blocks in rings around the cell's block, nearest ring first, until a ring cannot hold a
    nearer cell (ring ``r`` >= 1 is at least ``(r - 1) BLOCK + 1`` cells away). ``blocks``
    (ceil(X / BLOCK), ceil(Y / BLOCK), 1 + BLOCK^2) int16 lists each block's occupied cells
    (``_list_block``; a count of -1 until a search first needs it): a block's walls are read, not
    its every cell."""
    size_x, size_y = values.shape
    centre_a, centre_b = i // BLOCK, j // BLOCK
    for ring in range(max(blocks.shape[0], blocks.shape[1])):
        nearest = (ring - 1) * BLOCK + 1
        if ring >= 1 and nearest * nearest >= best:
            break
        for block_a in range(max(centre_a - ring, 0), min(centre_a + ring, blocks.shape[0] - 1) + 1):
            edge = block_a == centre_a - ring or block_a == centre_a + ring
            step = 1 if edge or ring == 0 else 2 * ring
            for block_b in range(centre_b - ring, centre_b + ring + 1, step):
                if block_b < 0 or block_b >= blocks.shape[1]:
                    continue
                low_a, high_a = block_a * BLOCK, min(block_a * BLOCK + BLOCK, size_x) - 1
                low_b, high_b = block_b * BLOCK, min(block_b * BLOCK + BLOCK, size_y) - 1
                gap_a, gap_b = max(low_a - i, 0, i - high_a), max(low_b - j, 0, j - high_b)
                if gap_a * gap_a + gap_b * gap_b >= best:
                    continue
                if blocks[block_a, block_b, 0] < 0:
                    _list_block(values, threshold, blocks, block_a, block_b, low_a, high_a, low_b, high_b)
                for n in range(1, blocks[block_a, block_b, 0] + 1):
                    a = low_a + blocks[block_a, block_b, n] // BLOCK
                    b = low_b + blocks[block_a, block_b, n] % BLOCK
                    best = min(best, float((a - i) ** 2 + (b - j) ** 2))
    return best


@njit(cache=True)
def _search(values, threshold, blocks, i, j, reach):
    """The distance (cells, float32) from cell (i, j) to the nearest occupied cell, at most
    ``reach`` (cells; the search ends there)."""
    best = _ring_search(values, threshold, i, j, NEAR_RINGS, reach * reach)
    if best > (NEAR_RINGS + 1) * (NEAR_RINGS + 1):  # a nearer cell may lie beyond the rings searched
        best = _block_search(values, threshold, blocks, i, j, best)
    return np.float32(math.sqrt(best))


@njit(cache=True)
def lookup(field, world, distance, gradient):
    """The distance (m) at world points ``world`` (N, 2), bilinear between the four nearest cell
    centres, into ``distance`` (N,), and its gradient (m/m) into ``gradient`` (N, 2). A cell's
    distance is searched the first time it is read (``_search``) and kept in ``memo`` (>= X * Y,),
    valid where ``stamps`` (>= X * Y,) holds this window's ``stamp`` (buffers reused from window to
    window: they are never cleared). A point outside the cell centres' grid (less than half a cell
    inside the window's edge, or beyond it) is interpolated between the two outermost rows or
    columns of centres with its own fraction of a cell: neither clamped nor extrapolated, but a
    sawtooth of one cell's period (as the reference filter's lookup; ``window_margin`` keeps the
    end points away from the edge). A ``gradient`` of no rows is left out.

    One function for the whole batch of points: numba passes arrays to a compiled call with a
    reference count, which costs more than a memoised read, so the per-point work stays in this loop.
    """
    values, threshold, blocks, memo, stamps, stamp, origin, resolution, reach = field
    size_y = values.shape[1]
    scale = np.float32(resolution)
    with_gradient = gradient.shape[0] > 0
    for k in range(world.shape[0]):
        cell_x = (world[k, 0] - origin[0]) / resolution - 0.5  # cell centres at integers
        cell_y = (world[k, 1] - origin[1]) / resolution - 0.5
        base_x, base_y = math.floor(cell_x), math.floor(cell_y)
        fx, fy = cell_x - base_x, cell_y - base_y
        i = min(max(int(base_x), 0), values.shape[0] - 2)
        j = min(max(int(base_y), 0), size_y - 2)
        for corner in range(4):
            a, b = i + (corner & 1), j + (corner >> 1)
            if stamps[a * size_y + b] != stamp:
                memo[a * size_y + b] = _search(values, threshold, blocks, a, b, reach)
                stamps[a * size_y + b] = stamp
        d00, d10 = memo[i * size_y + j] * scale, memo[(i + 1) * size_y + j] * scale
        d01, d11 = memo[i * size_y + j + 1] * scale, memo[(i + 1) * size_y + j + 1] * scale
        distance[k] = (d00 * (1 - fx) + d10 * fx) * (1 - fy) + (d01 * (1 - fx) + d11 * fx) * fy
        if with_gradient:
            gradient[k, 0] = ((d10 - d00) * (1 - fy) + (d11 - d01) * fy) / resolution
            gradient[k, 1] = ((d01 - d00) * (1 - fx) + (d11 - d10) * fx) / resolution


@njit(cache=True)
def place(pose, points, world):
    """``points`` (N, 2) in the frame of ``pose`` (3,) written to ``world`` (N, 2) in its parent's."""
    cos_t, sin_t = math.cos(pose[2]), math.sin(pose[2])
    for k in range(points.shape[0]):
        world[k, 0] = pose[0] + cos_t * points[k, 0] - sin_t * points[k, 1]
        world[k, 1] = pose[1] + sin_t * points[k, 0] + cos_t * points[k, 1]


@njit(cache=True)
def _wrap(angle):
    """``angle`` (rad) wrapped to (-pi, pi], as ``mazeslam.core.geometry.wrap_angle``."""
    return math.pi - np.mod(math.pi - angle, 2 * math.pi)


@njit(cache=True)
def _prior_terms(x, y, theta, prior, information):
    """The prior's part of one Gauss-Newton step at pose (x, y, theta): its gradient ``information
    offset`` (3 scalars) and half its squared norm ``0.5 offset^T information offset``, for the
    offset from ``prior`` (3,) (heading wrapped) and ``information`` (3, 3)."""
    offset = (x - prior[0], y - prior[1], _wrap(theta - prior[2]))
    g0 = information[0, 0] * offset[0] + information[0, 1] * offset[1] + information[0, 2] * offset[2]
    g1 = information[1, 0] * offset[0] + information[1, 1] * offset[1] + information[1, 2] * offset[2]
    g2 = information[2, 0] * offset[0] + information[2, 1] * offset[1] + information[2, 2] * offset[2]
    return g0, g1, g2, 0.5 * (offset[0] * g0 + offset[1] * g1 + offset[2] * g2)


@njit(cache=True)
def _solve_symmetric(h00, h01, h02, h11, h12, h22, b0, b1, b2):
    """``H^-1 b`` for a symmetric positive definite ``H`` (3, 3) given by its upper triangle, by
    Cholesky (``H = L L^T``): three scalars."""
    l00 = math.sqrt(h00)
    l10, l20 = h01 / l00, h02 / l00
    l11 = math.sqrt(h11 - l10 * l10)
    l21 = (h12 - l20 * l10) / l11
    l22 = math.sqrt(h22 - l20 * l20 - l21 * l21)
    z0 = b0 / l00
    z1 = (b1 - l10 * z0) / l11
    z2 = (b2 - l20 * z0 - l21 * z1) / l22
    x2 = z2 / l22
    x1 = (z1 - l21 * x2) / l11
    x0 = (z0 - l10 * x1 - l20 * x2) / l00
    return x0, x1, x2


@njit(cache=True)
def refine(field, points, prior, information, settings, start):
    """The pose (3,) maximising the end points' likelihood times the Gaussian prior, by
    iteratively reweighted Gauss-Newton from ``start`` (3,): ``points`` (N, 2) robot frame,
    ``prior`` (3,) and its ``information`` (3, 3); ``settings`` = (the stages' sigmas (S,) m,
    iterations per stage, the likelihood's scale and floor) (``MatchParams``).

    Each step solves ``(information + sum_k w_k J_k^T J_k) delta = information offset + sum_k
    w_k J_k^T d_k`` for the points' distances ``d_k``, their Jacobians ``J_k = (dd/dx, dd/dy,
    dd/dtheta)`` and the weights ``w_k = scale l_k / (l_k + floor) / sigma^2`` of their
    likelihoods ``l_k = exp(-d_k^2 / (2 sigma^2))``, then moves the pose by ``-delta``."""
    schedule, iterations, scale, floor = settings
    count = points.shape[0]
    arms, world = np.empty((count, 2)), np.empty((count, 2))
    distance, gradient = np.empty(count), np.empty((count, 2))
    x, y, theta = start[0], start[1], start[2]
    for sigma in schedule:
        for _ in range(iterations):
            cos_t, sin_t = math.cos(theta), math.sin(theta)
            for k in range(count):
                arms[k, 0] = cos_t * points[k, 0] - sin_t * points[k, 1]
                arms[k, 1] = sin_t * points[k, 0] + cos_t * points[k, 1]
                world[k, 0], world[k, 1] = x + arms[k, 0], y + arms[k, 1]
            lookup(field, world, distance, gradient)
            b0, b1, b2, _half = _prior_terms(x, y, theta, prior, information)
            h00, h01, h02 = information[0, 0], information[0, 1], information[0, 2]
            h11, h12, h22 = information[1, 1], information[1, 2], information[2, 2]
            for k in range(count):
                g0, g1 = gradient[k, 0], gradient[k, 1]
                g2 = g1 * arms[k, 0] - g0 * arms[k, 1]
                likelihood = math.exp(-0.5 * (distance[k] / sigma) ** 2)
                weight = scale * likelihood / (likelihood + floor) / sigma**2
                pull = weight * distance[k]
                b0, b1, b2 = b0 + pull * g0, b1 + pull * g1, b2 + pull * g2
                h00, h01, h02 = h00 + weight * g0 * g0, h01 + weight * g0 * g1, h02 + weight * g0 * g2
                h11, h12, h22 = h11 + weight * g1 * g1, h12 + weight * g1 * g2, h22 + weight * g2 * g2
            d0, d1, d2 = _solve_symmetric(h00, h01, h02, h11, h12, h22, b0, b1, b2)
            x, y, theta = x - d0, y - d1, _wrap(theta - d2)
    return np.array([x, y, theta])


#: The running product of the points' likelihoods is rescaled below this, so that it cannot underflow.
_SMALL, _LOG_SMALL = 1e-200, math.log(1e-200)
#: Side of the block of cells (corners) a point's lookups share across the poses of one heading.
SHARED = 4


@njit(cache=True)
def _heading_group(poses, done, group):
    """The indices of the first pose of ``poses`` (K, 3) not ``done`` (K,) bool and of every later
    one with the same heading, into ``group`` (K,), marked done; returns how many."""
    first = 0
    while done[first]:
        first += 1
    members = 0
    for p in range(first, poses.shape[0]):
        if not done[p] and poses[p, 2] == poses[first, 2]:
            group[members] = p
            members += 1
            done[p] = True
    return members


@njit(cache=True)
def objective(
    field,
    poses,
    points,
    prior,
    information,
    sigma,
    scale,
    floor,
):
    """``log p(z | m, x) - 0.5 (x - prior)^T information (x - prior)`` (K,) at ``poses`` (K, 3) for
    end points ``points`` (N, 2) robot frame (the heading offset wrapped).

    ``log p(z | m, x) = scale sum_k log(exp(-d_k^2 / (2 sigma^2)) + floor)``, d_k ``lookup``'s
    distance at point k placed by the pose (``place``), with the same arithmetic. The poses are
    taken a heading at a time, point by point: the poses of one heading place a point within a few
    cells of each other (the proposal's stencil: within a cell), so that their lookups read one
    block of at most ``SHARED`` x ``SHARED`` corners, searched and read once for all of them
    (farther apart, each reads its own four). The sum is the log of a running product of the
    factors (each in [floor, 1 + floor]), rescaled before it underflows: one logarithm a pose, not
    one a point.
    """
    values, threshold, blocks, memo, stamps, stamp, origin, resolution, reach = field
    size_x, size_y = values.shape
    cell = np.float32(resolution)
    count = poses.shape[0]
    products, totals = np.ones(count), np.zeros(count)
    done, group = np.zeros(count, dtype=np.bool_), np.empty(count, dtype=np.int64)
    rows, columns, fractions = np.empty(count, np.int64), np.empty(count, np.int64), np.empty((count, 2))
    corners = np.empty((SHARED, SHARED), dtype=np.float32)
    placed = 0
    while placed < count:
        members = _heading_group(poses, done, group)
        placed += members
        cos_t, sin_t = math.cos(poses[group[0], 2]), math.sin(poses[group[0], 2])
        for k in range(points.shape[0]):
            # 1. The point placed by each pose of the heading: its cell and fractions, as ``lookup``'s.
            along_x, across_x = cos_t * points[k, 0], sin_t * points[k, 1]
            along_y, across_y = sin_t * points[k, 0], cos_t * points[k, 1]
            low_i, low_j, high_i, high_j = size_x, size_y, -1, -1
            for m in range(members):
                p = group[m]
                cell_x = (poses[p, 0] + along_x - across_x - origin[0]) / resolution - 0.5
                cell_y = (poses[p, 1] + along_y + across_y - origin[1]) / resolution - 0.5
                base_x, base_y = math.floor(cell_x), math.floor(cell_y)
                fractions[m, 0], fractions[m, 1] = cell_x - base_x, cell_y - base_y
                rows[m] = min(max(int(base_x), 0), size_x - 2)
                columns[m] = min(max(int(base_y), 0), size_y - 2)
                low_i, high_i = min(low_i, rows[m]), max(high_i, rows[m])
                low_j, high_j = min(low_j, columns[m]), max(high_j, columns[m])
            # 2. Each pose's four corners, searched where not yet known: one block read once for all
            # of them where it fits in ``corners``, else the pose's own four.
            shared = high_i - low_i + 2 <= SHARED and high_j - low_j + 2 <= SHARED
            first_i = first_j = 0
            for m in range(members):
                i, j, fx, fy = rows[m], columns[m], fractions[m, 0], fractions[m, 1]
                if m == 0 or not shared:
                    first_i, last_i = (low_i, high_i + 1) if shared else (i, i + 1)
                    first_j, last_j = (low_j, high_j + 1) if shared else (j, j + 1)
                    for a in range(first_i, last_i + 1):
                        for b in range(first_j, last_j + 1):
                            if stamps[a * size_y + b] != stamp:
                                memo[a * size_y + b] = _search(values, threshold, blocks, a, b, reach)
                                stamps[a * size_y + b] = stamp
                            corners[a - first_i, b - first_j] = memo[a * size_y + b]
                # 3. Its distance, bilinear between them, into its running product.
                a, b = i - first_i, j - first_j
                d00, d10 = corners[a, b] * cell, corners[a + 1, b] * cell
                d01, d11 = corners[a, b + 1] * cell, corners[a + 1, b + 1] * cell
                distance = (d00 * (1 - fx) + d10 * fx) * (1 - fy) + (d01 * (1 - fx) + d11 * fx) * fy
                p = group[m]
                products[p] *= math.exp(-0.5 * (distance / sigma) ** 2) + floor
                if products[p] < _SMALL:
                    products[p] /= _SMALL
                    totals[p] += _LOG_SMALL
    scores = np.empty(count)
    for p in range(count):
        half_norm = _prior_terms(poses[p, 0], poses[p, 1], poses[p, 2], prior, information)[3]
        scores[p] = scale * (totals[p] + math.log(products[p])) - half_norm
    return scores


@njit(cache=True)
def overlap(field, pose, points, within):
    """Share of ``points`` (N, 2) robot frame that lie within ``within`` m of an occupied cell at ``pose`` (3,)."""
    count = points.shape[0]
    world, distance = np.empty((count, 2)), np.empty(count)
    place(pose, points, world)
    lookup(field, world, distance, np.empty((0, 2)))
    return np.sum(distance <= within) / max(count, 1)


@njit(cache=True)
def match(field, points, prior, information, settings, within):
    """``refine`` from the prior, then ``overlap`` at the refined pose: the pose (3,) and the share
    of ``points`` (N, 2) within ``within`` m of an occupied cell there."""
    pose = refine(field, points, prior, information, settings, prior)
    return pose, overlap(field, pose, points, within)


@njit(cache=True)
def proposal(
    field,
    points,
    centre,
    prior,
    information,
    steps,
    sigma,
    scale,
    floor,
):
    """The improved proposal around ``centre`` (3,): the scores ``log tau_j`` (the likelihood of
    ``points`` (N, 2) times the prior) of the poses ``centre + steps_j`` (``steps`` (K, 3)), their
    normaliser ``log eta = log sum_j tau_j``, and the ``tau``-weighted mean (3,) and covariance (3, 3)
    of the steps (plus 1e-10 on the diagonal)."""
    scores = objective(
        field,
        centre + steps,
        points,
        prior,
        information,
        sigma,
        scale,
        floor,
    )
    top = scores.max()
    log_eta = top + math.log(np.sum(np.exp(scores - top)))
    weights = np.exp(scores - log_eta)
    mean = weights @ steps
    spread = steps - mean
    covariance = (spread * weights[:, None]).T @ spread + 1e-10 * np.eye(3)
    return log_eta, mean, covariance


@njit(cache=True)
def mark(source, level, marks, rows, columns, count, origin, resolution, x0, y0, cos_t, sin_t):
    """Mark in ``marks`` (X, Y) with ``level`` the window cells of the points ``source`` (K, 2)
    (robot frame, the robot at (x0, y0) heading with cos_t, sin_t) whose mark is lower, appending
    each newly marked cell's row and column to ``rows`` and ``columns`` after their first ``count``;
    returns the new count. Samples outside the window are left out."""
    size_x, size_y = marks.shape
    for k in range(source.shape[0]):
        i = math.floor((x0 + cos_t * source[k, 0] - sin_t * source[k, 1] - origin[0]) / resolution)
        j = math.floor((y0 + sin_t * source[k, 0] + cos_t * source[k, 1] - origin[1]) / resolution)
        if 0 <= i < size_x and 0 <= j < size_y:  # without branches on the marks, which samples flip at random
            before = marks[i, j]
            rows[count], columns[count] = i, j
            count += before == 0
            marks[i, j] = max(before, level)
    return count


@njit(cache=True)
def _updated(value, level, miss, hit, low, high):
    """A cell's log-odds ``value`` after a scan that marked it ``level`` (1: crossed, gets ``miss``;
    2: a beam ends in it, gets ``hit``), clamped to [``low``, ``high``] (float32 scalars, inline)."""
    change = np.float32(hit) if level == 2 else np.float32(miss)
    return min(max(value + change, low), high)


@njit(cache=True)
def integrate(values, origin, resolution, free, hits, x0, y0, cos_t, sin_t, miss, hit, clamp, tile_size):
    """Add one scan to ``values`` (X, Y) float32 in place, the robot at (x0, y0) heading with
    ``cos_t``, ``sin_t``: each cell a sample of ``free`` (F, 2) (robot frame, m) falls in gets
    ``miss`` once, each cell a point of ``hits`` (H, 2) falls in gets ``hit`` once and no miss, both
    clamped to [-clamp, clamp]. Samples outside the window are left out. Returns the tiles changed:
    bool (X / tile_size, Y / tile_size)."""
    size_x, size_y = values.shape
    marks = np.zeros((size_x, size_y), dtype=np.uint8)  # 1: a beam crosses the cell, 2: a beam ends in it
    rows = np.empty(free.shape[0] + hits.shape[0], dtype=np.int32)
    columns = np.empty_like(rows)
    count = mark(free, 1, marks, rows, columns, 0, origin, resolution, x0, y0, cos_t, sin_t)
    count = mark(hits, 2, marks, rows, columns, count, origin, resolution, x0, y0, cos_t, sin_t)
    changed = np.zeros((size_x // tile_size, size_y // tile_size), dtype=np.bool_)
    tile_row, tile_column = np.arange(size_x) // tile_size, np.arange(size_y) // tile_size
    low, high = np.float32(-clamp), np.float32(clamp)
    for k in range(count):
        i, j = rows[k], columns[k]
        values[i, j] = _updated(values[i, j], marks[i, j], miss, hit, low, high)
        changed[tile_row[i], tile_column[j]] = True
    return changed


#: ``match_all``'s outcome per particle: nothing to match (no map, or no occupied cell near the
#: points), the match accepted (the proposal is scored), or the match failed (the caller rescues it).
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
    reach,
):
    """Each particle's scan match and proposal against its own map.

    Args:
        tiles, table, lower, tile_size: the pool (module docstring); resolution: cell size, m.
        mapped: (P,) bool the particle holds a tile.
        crop_low, crop_high: (P, 2) int64 the global cells (high exclusive) of each particle's
            likelihood field, whose cell [0, 0]'s corner is at ``crop_origins`` (P, 2), m.
        points: (N, 2) the end points to match, robot frame, m.
        predicted: (P, 3) each particle's predicted pose (the prior's mean, world frame).
        information: (3, 3) the prior's information; settings, within: ``match``'s.
        min_overlap: the share of points near a wall at which the match is accepted.
        steps, sigma, scale, floor: ``proposal``'s; threshold: log-odds of an occupied cell;
        reach: the distance (cells) at which the likelihood field's searches end.

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
    memo, stamps = np.empty(largest, dtype=np.float32), np.zeros(largest, dtype=np.int32)
    for p in range(count):
        if not mapped[p]:
            continue
        size_x, size_y = crop_high[p, 0] - crop_low[p, 0], crop_high[p, 1] - crop_low[p, 1]
        values = scratch[: size_x * size_y].reshape((size_x, size_y))
        gather(tiles, table[p], lower, tile_size, crop_low[p], values)
        if not any_occupied(values, threshold):
            continue
        blocks = empty_blocks(size_x, size_y)
        field = (values, threshold, blocks, memo, stamps, p + 1, crop_origins[p], resolution, reach)
        modes[p], share = match(field, points, predicted[p], information, settings, within)
        if share < min_overlap:
            status[p] = FAILED
            continue
        status[p] = ACCEPTED
        log_etas[p], means[p], covariances[p] = proposal(
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
    [-clamp, clamp] (``integrate``), within the particle's window: tiles ``window_lower`` ..
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
        marked = mark(free_samples, 1, window_marks, rows, columns, 0, *placed)
        marked = mark(hits, 2, window_marks, rows, columns, marked, *placed)
        offset_a, offset_b = window_lower[p, 0] - lower[0], window_lower[p, 1] - lower[1]
        for k in range(marked):
            i, j = rows[k], columns[k]
            level, window_marks[i, j] = window_marks[i, j], 0  # clean for the next particle
            a, b = offset_a + tile_of[i], offset_b + tile_of[j]
            slot = table[p, a, b]
            if slot < 0 or owners[slot] != 1:  # once a tile: a compiled call costs more than a cell
                slot = _writable_slot(tiles, owners, free, free_count, table, p, a, b)
            cell_a, cell_b = i - tile_of[i] * tile_size, j - tile_of[j] * tile_size
            tiles[slot, cell_a, cell_b] = _updated(tiles[slot, cell_a, cell_b], level, miss, hit, low, high)
    return count
