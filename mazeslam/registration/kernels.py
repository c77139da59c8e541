"""Compiled kernels of the laser odometry's point-to-line ICP (numba, ``cache=True``: compiled once
per machine and kept on disk beside this module).

Imported only where scans are matched (``mazeslam.registration.scan_matching`` imports it inside
its functions): numba takes about 0.15 s to import. A match runs about 20 Gauss-Newton iterations,
each a nearest-neighbour query for every point of the scan; done in numpy with a k-d tree, the
calls' own overhead was most of the time, so the whole iteration is one compiled loop here.

Nearest neighbours: the reference scan's points (N, 2) are sorted into square buckets of side
``cell`` m over their bounding box (``buckets``: ``origin`` (2,) m of bucket [0, 0]'s corner,
``shape`` (2,), ``starts`` (shape[0] * shape[1] + 1,) the first of each bucket's points in
``order`` (N,), bucket ``(i, j)`` at ``i * shape[1] + j``). A query searches rings of buckets
around its own, nearest first, and stops once a ring cannot hold a point nearer than the ones
found or than the bound (``nearest``): exactly the nearest points, as a k-d tree finds them, and
of points equally near the lower index first, so that the result does not depend on the buckets.

The kernels, in the order a match uses them (``mazeslam.registration.scan_matching``):

1. ``buckets``: the reference scan's points sorted into buckets; ``surface_normals``: the normal of
   the surface at each point from its nearest neighbours.
2. ``refine``: Gauss-Newton on ``match_scan``'s objective, stage by stage of correspondence
   distance.
3. ``score``: the objective with unpaired points capped, and the overlap, at the result.
4. ``information``: the data term's Hessian at a pose (``match_information``).

One module for all of them: numba renews the cached code of a compiled function only when its own
file changes, so a kernel that calls another must live in the same file.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

#: Smallest side of a bucket, m, larger where the scan spans so much that the buckets would number
#: more than ``MAX_BUCKETS``. The result does not depend on it, only the time: on the CARMEN logs
#: 0.1-0.5 m buckets take 5-25 % of each other's (0.2 m among the fastest).
MIN_CELL = 0.2
MAX_BUCKETS = 1 << 16


@njit(cache=True)
def buckets(points):
    """The points (N, 2) m sorted into square buckets: ``(cell, origin (2,), shape (2,), starts
    (B + 1,), order (N,))`` as the module docstring describes."""
    low_x, low_y = points[:, 0].min(), points[:, 1].min()
    span_x, span_y = points[:, 0].max() - low_x, points[:, 1].max() - low_y
    cell = max(MIN_CELL, math.sqrt(span_x * span_y / MAX_BUCKETS))
    shape = np.array([int(span_x / cell) + 1, int(span_y / cell) + 1])
    origin = np.array([low_x, low_y])
    index = np.empty(points.shape[0], dtype=np.int64)
    counts = np.zeros(shape[0] * shape[1] + 1, dtype=np.int64)
    for k in range(points.shape[0]):
        i = min(int((points[k, 0] - low_x) / cell), shape[0] - 1)
        j = min(int((points[k, 1] - low_y) / cell), shape[1] - 1)
        index[k] = i * shape[1] + j
        counts[index[k] + 1] += 1
    starts = np.cumsum(counts)
    filled = starts[:-1].copy()
    order = np.empty(points.shape[0], dtype=np.int64)
    for k in range(points.shape[0]):
        order[filled[index[k]]] = k
        filled[index[k]] += 1
    return cell, origin, shape, starts, order


@njit(cache=True)
def nearest(points, grid, x, y, found, squared):
    """The points of ``points`` (N, 2) nearest to (x, y), nearest first (of points equally near, the
    lower index first), into ``found`` (K,) int64 with their squared distances (m^2) in ``squared``
    (K,), each below what ``squared`` holds on entry (the bound: the same value in every entry;
    ``found`` -1 and ``squared`` the bound where fewer points are within it). ``grid``: the
    points' ``buckets``; the search visits rings of buckets around (x, y)'s, nearest first, until
    a ring cannot hold a point nearer than the K-th."""
    cell, origin, shape, starts, order = grid
    count = found.shape[0]
    centre_i, centre_j = math.floor((x - origin[0]) / cell), math.floor((y - origin[1]) / cell)
    farthest = max(centre_i, shape[0] - 1 - centre_i, centre_j, shape[1] - 1 - centre_j)  # its ring holds every bucket
    for ring in range(farthest + 1):
        if ring >= 1:  # the nearest a point outside rings 0 .. ring - 1 can be
            low_x, low_y = origin[0] + (centre_i - ring + 1) * cell, origin[1] + (centre_j - ring + 1) * cell
            side = (2 * ring - 1) * cell
            gap = min(x - low_x, low_x + side - x, y - low_y, low_y + side - y)
            if gap * gap >= squared[count - 1]:
                return
        for i in range(max(centre_i - ring, 0), min(centre_i + ring, shape[0] - 1) + 1):
            edge = i == centre_i - ring or i == centre_i + ring
            step = 1 if edge or ring == 0 else 2 * ring
            for j in range(centre_j - ring, centre_j + ring + 1, step):
                if j < 0 or j >= shape[1]:
                    continue
                bucket = i * shape[1] + j
                for slot in range(starts[bucket], starts[bucket + 1]):
                    k = order[slot]
                    dx, dy = x - points[k, 0], y - points[k, 1]
                    distance = dx * dx + dy * dy
                    place = count
                    while place > 0 and (  # insertion into the list, sorted by distance, then index
                        distance < squared[place - 1] or (distance == squared[place - 1] and k < found[place - 1])
                    ):
                        if place < count:
                            squared[place], found[place] = squared[place - 1], found[place - 1]
                        place -= 1
                    if place < count:
                        squared[place], found[place] = distance, k


@njit(cache=True)
def surface_normals(points, grid, neighbours, max_flatness):
    """The unit normal (N, 2) of the surface at each of ``points`` (N, 2) m and whether that
    surface is straight (N,) bool: the eigenvector of the smaller eigenvalue of the scatter of its
    ``neighbours`` nearest points (itself among them) about their mean, straight where that
    eigenvalue is at most ``max_flatness`` times the larger (``scan_matching.ReferenceScan``)."""
    count = points.shape[0]
    normals, straight = np.empty((count, 2)), np.empty(count, dtype=np.bool_)
    found, squared = np.empty(neighbours, dtype=np.int64), np.empty(neighbours)
    for n in range(count):
        found[:], squared[:] = -1, math.inf
        nearest(points, grid, points[n, 0], points[n, 1], found, squared)
        mean_x = mean_y = 0.0
        for k in found:
            mean_x, mean_y = mean_x + points[k, 0], mean_y + points[k, 1]
        mean_x, mean_y = mean_x / neighbours, mean_y / neighbours
        xx = xy = yy = 0.0
        for k in found:
            dx, dy = points[k, 0] - mean_x, points[k, 1] - mean_y
            xx, xy, yy = xx + dx * dx, xy + dx * dy, yy + dy * dy
        half_sum, half_difference = 0.5 * (xx + yy), 0.5 * (xx - yy)
        radius = math.sqrt(half_difference * half_difference + xy * xy)
        smaller, larger = half_sum - radius, half_sum + radius
        # the eigenvector of the smaller: (xy, smaller - xx) or (smaller - yy, xy), the longer of the two
        first_x, first_y = xy, smaller - xx
        second_x, second_y = smaller - yy, xy
        if first_x * first_x + first_y * first_y >= second_x * second_x + second_y * second_y:
            vector_x, vector_y = first_x, first_y
        else:
            vector_x, vector_y = second_x, second_y
        length = math.sqrt(vector_x * vector_x + vector_y * vector_y)
        if length == 0.0:  # isotropic or a single point: any direction
            vector_x, vector_y, length = 1.0, 0.0, 1.0
        normals[n, 0], normals[n, 1] = vector_x / length, vector_y / length
        straight[n] = smaller <= max_flatness * max(larger, 1e-12)
    return normals, straight


@njit(cache=True)
def _wrap(angle):
    """``angle`` (rad) wrapped to (-pi, pi], as ``mazeslam.core.geometry.wrap_angle``."""
    return math.pi - np.mod(math.pi - angle, 2 * math.pi)


@njit(cache=True)
def _normal_equations(reference, points, pose, distance, scale, point_noise, hessian, gradient):
    """Add to ``hessian`` (3, 3) and ``gradient`` (3,) the point-to-line terms of ``points`` (K, 2)
    (robot frame) placed at ``pose`` (3,): for each point whose nearest reference point lies
    within ``distance`` (m, strictly) on a straight surface, ``w J^T J`` and ``w J^T r`` for its
    distance ``r`` (m) along the surface normal, the Jacobian ``J`` (3,) of that distance and its
    Huber weight ``w = scale min(1, point_noise / |r|)``. ``reference``: ``(points (N, 2),
    normals (N, 2), straight (N,) bool, buckets)``."""
    reference_points, normals, straight, grid = reference
    cos_t, sin_t = math.cos(pose[2]), math.sin(pose[2])
    found, squared = np.empty(1, dtype=np.int64), np.empty(1)
    for k in range(points.shape[0]):
        x = pose[0] + cos_t * points[k, 0] - sin_t * points[k, 1]
        y = pose[1] + sin_t * points[k, 0] + cos_t * points[k, 1]
        found[0], squared[0] = -1, distance * distance
        nearest(reference_points, grid, x, y, found, squared)
        partner = found[0]
        if partner < 0 or not straight[partner]:
            continue
        normal_x, normal_y = normals[partner, 0], normals[partner, 1]
        residual = (x - reference_points[partner, 0]) * normal_x + (y - reference_points[partner, 1]) * normal_y
        row = (normal_x, normal_y, normal_y * (x - pose[0]) - normal_x * (y - pose[1]))
        weight = scale / max(1.0, abs(residual) / point_noise)
        for a in range(3):
            gradient[a] += weight * row[a] * residual
            for b in range(3):
                hessian[a, b] += weight * row[a] * row[b]


@njit(cache=True)
def refine(reference, points, prior, prior_information, start, distances, iterations, scale, point_noise):
    """Gauss-Newton from ``start`` (3,) on the point-to-line objective plus the prior (mean
    ``prior`` (3,), information (3, 3)): ``iterations`` steps at each correspondence distance of
    ``distances`` (S,) m, coarse to fine. Returns the pose (3,) (``scan_matching.match_scan``)."""
    pose = start.copy()
    for distance in distances:
        for _ in range(iterations):
            offset = pose - prior
            offset[2] = _wrap(offset[2])
            hessian, gradient = np.zeros((3, 3)), np.zeros(3)
            _normal_equations(reference, points, pose, distance, scale, point_noise, hessian, gradient)
            step = np.linalg.solve(hessian + prior_information, gradient + prior_information @ offset)
            pose = pose - step
            pose[2] = _wrap(pose[2])
    return pose


@njit(cache=True)
def score(reference, points, pose, cap):
    """At ``pose`` (3,): the sum over ``points`` (K, 2) of the squared distance along the normal
    to the nearest reference point's surface, at most ``cap``^2, ``cap``^2 for a point with no
    reference point within ``cap`` m (m^2); and the fraction of points that have one."""
    reference_points, normals, _, grid = reference
    cos_t, sin_t = math.cos(pose[2]), math.sin(pose[2])
    found, squared = np.empty(1, dtype=np.int64), np.empty(1)
    total, paired = 0.0, 0
    for k in range(points.shape[0]):
        x = pose[0] + cos_t * points[k, 0] - sin_t * points[k, 1]
        y = pose[1] + sin_t * points[k, 0] + cos_t * points[k, 1]
        found[0], squared[0] = -1, np.nextafter(cap * cap, math.inf)  # a point exactly cap away is paired
        nearest(reference_points, grid, x, y, found, squared)
        partner = found[0]
        if partner < 0:
            total += cap * cap
            continue
        residual = (x - reference_points[partner, 0]) * normals[partner, 0] + (
            y - reference_points[partner, 1]
        ) * normals[partner, 1]
        total += min(residual * residual, cap * cap)
        paired += 1
    return total, paired / max(points.shape[0], 1)


@njit(cache=True)
def information(reference, points, pose, distance, scale, point_noise):
    """The data term's Gauss-Newton Hessian (3, 3) at ``pose`` (3,): ``_normal_equations``'s
    ``sum w J^T J`` at correspondence distance ``distance`` m, without the prior."""
    hessian, gradient = np.zeros((3, 3)), np.zeros(3)
    _normal_equations(reference, points, pose, distance, scale, point_noise, hessian, gradient)
    return hessian
