"""Local and loop-closure edges: a scan matched against a submap of other scans, by the project's
correlative search (``mazeslam.registration.correlative``) and point-to-line refinement
(``mazeslam.registration.scan_matching.match_scan``), kept only when the match is unambiguous.

Which pairs are tried (``candidate_pairs``), from the current estimate of the poses: the queries are
the keyframes (a scan after ``keyframe_distance`` of travel or ``keyframe_turn`` of turning since
the last keyframe). A query is matched

* locally, against keyframes a few metres before it and a few metres after it (``local_anchors``,
  both ways: the same stretch of path, but not the neighbour the sequential edge already ties it
  to): what bounds the drift along a corridor and can decide a step the scan-to-scan match got
  wrong. The map ahead is what a smoother has and a filter has not: a scan at a corner is matched
  to the corridor it turns into as well as to the one it leaves;
* for closures, against the keyframes at least ``min_loop_path`` metres back along the path but
  within ``search_radius`` plus the window's reach of it by the estimate, the nearest of each
  separate visit of the place, at most ``closures_per_scan``.

The submap of an anchor keyframe is the returns of the keyframes within ``submap_path`` metres of
it along the path (and beyond the query's neighbouring keyframe on the anchor's side: before it for
an anchor behind the query, after it for one ahead), placed by the estimate in the anchor's robot
frame and thinned to one point per ``voxel``. The search window around the estimate's relative pose
(and around each alternative the caller passes: ``match_to_submap`` takes several guesses and
compares their modes together) has the standard deviation the sequential chain between the two
scans states (its summed covariances, the heading's spread swinging the path, ``chain_window``), at
least ``min_window`` and at most ``max_window``.

The ambiguity test (as Olson's and Karto's loop closers): the search's best distinct basins are each
refined; refined poses within ``mode_distance`` and ``mode_turn`` of a better one are the same mode.
The match is accepted when the best mode's points overlap the submap (``min_overlap``), the second
best mode's objective is at least ``1 / ambiguity_ratio`` times the best's, and the match fixes the
position to ``max_sigma`` (a corridor that only fixes the motion across it is refused). Its
covariance is the refinement's data term alone (``mazeslam.posegraph.sequential.posterior_covariance``
without a prior: the data term's Hessian with the measured ``variance_scale``): the window is the
sequential chain's own covariance, already in the graph, and as the edge's prior it would count the
chain twice and let a corridor match pass the ``max_sigma`` test on the window alone.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from mazeslam.core.geometry import relative, transform_points, wrap_angle
from mazeslam.posegraph.graph import EdgeKind
from mazeslam.posegraph.params import ClosureParams, SequentialParams
from mazeslam.posegraph.sequential import posterior_covariance
from mazeslam.registration.correlative import CorrelativeParams, LikelihoodGrid, correlative_candidates
from mazeslam.registration.scan_matching import ReferenceScan, ScanMatchParams, match_information, match_scan


@dataclass(frozen=True)
class SubmapMatch:
    """A scan matched to a submap: the pose (3,) of the scan in the anchor's robot frame, its
    covariance (3, 3), the overlap, the best and second-best modes' objectives (inf: no second),
    whether it is accepted and why not (``refusal``: "" when accepted), and every distinct mode's
    pose (M, 3), best first."""

    pose: np.ndarray
    covariance: np.ndarray
    overlap: float
    best: float
    second: float
    refusal: str
    modes: np.ndarray

    @property
    def accepted(self) -> bool:
        return not self.refusal


@dataclass
class Submap:
    """Points (N, 2) in the anchor's robot frame, their reference for refinement, and their
    likelihood grids by search resolution (made as searches need them)."""

    points: np.ndarray
    reference: ReferenceScan
    grids: dict = field(default_factory=dict)

    def grid(self, params: CorrelativeParams) -> LikelihoodGrid:
        """The likelihood grid of the points with ``params``' cells and spread."""
        key = (params.resolution, params.sigma)
        if key not in self.grids:
            self.grids[key] = LikelihoodGrid(self.points, params)
        return self.grids[key]


def search_params(window: np.ndarray, params: ClosureParams) -> CorrelativeParams:
    """The correlative search for a window of covariance (3, 3): ``params.correlative``'s cells,
    spread and turn step, coarsened by a power of 2 until the window's position standard deviation
    spans at most ``window_cells`` cells (a wide window is searched coarse, then refined)."""
    base = params.correlative
    factor = 1
    while math.sqrt(window[0, 0]) > params.window_cells * base.resolution * factor and factor < 8:
        factor *= 2
    if factor == 1:
        return base
    return replace(
        base, resolution=base.resolution * factor, sigma=base.sigma * factor, turn_step=base.turn_step * factor
    )


def path_lengths(poses: np.ndarray) -> np.ndarray:
    """Distance travelled (S,) from the first pose to each pose of ``poses`` (S, 3), m."""
    steps = np.hypot(*np.diff(poses[:, :2], axis=0).T)
    return np.concatenate([[0.0], np.cumsum(steps)])


def keyframes(poses: np.ndarray, distance: float, turn: float) -> np.ndarray:
    """Indices (K,) of the keyframes of ``poses`` (S, 3): the first, then each pose after at least
    ``distance`` m of travel or ``turn`` rad of turning (summed along the path) since the last."""
    chosen, travelled, turned = [0], 0.0, 0.0
    for index in range(1, len(poses)):
        step = relative(poses[index - 1], poses[index])
        travelled += math.hypot(step[0], step[1])
        turned += abs(step[2])
        if travelled >= distance or turned >= turn:
            chosen.append(index)
            travelled, turned = 0.0, 0.0
    return np.array(chosen)


def voxel_thinned(points: np.ndarray, voxel: float) -> np.ndarray:
    """The first point (in order) of each ``voxel``-sided square cell occupied by ``points`` (N, 2)."""
    if not len(points):
        return points
    cells = np.floor(points / voxel).astype(np.int64)
    _, first = np.unique(cells, axis=0, return_index=True)
    return points[np.sort(first)]


def build_submap(
    anchor: int,
    members: np.ndarray,
    poses: np.ndarray,
    scan_points: list[np.ndarray],
    params: ClosureParams,
    scan_params: ScanMatchParams,
) -> Submap | None:
    """The submap of scans ``members`` (indices) placed by ``poses`` (S, 3) in the robot frame of scan
    ``anchor``; None when it has too few points to define surfaces."""
    placed = [transform_points(relative(poses[anchor], poses[k]), scan_points[k]) for k in members]
    points = voxel_thinned(np.concatenate(placed) if placed else np.zeros((0, 2)), params.voxel)
    if len(points) < max(scan_params.neighbours, 10):
        return None
    return Submap(points, ReferenceScan(points, scan_params))


def match_to_submap(
    submap: Submap,
    points: np.ndarray,
    guess: np.ndarray,
    window: np.ndarray,
    params: ClosureParams,
    scan_params: ScanMatchParams,
    sequential: SequentialParams,
) -> SubmapMatch:
    """Match ``points`` (K, 2) (robot frame) to ``submap`` around ``guess`` (3,) (the scan's pose in
    the anchor's frame by the estimate) within ``window`` (3, 3), the search's covariance; the
    ambiguity test of the module docstring. ``guess`` may also be (G, 3): the same window searched
    around each guess (the estimate's and its alternatives where a step between the two scans is
    ambiguous, ``mazeslam.posegraph.laser_graph``), the modes of every search compared together."""
    search = search_params(window, params)
    refined = []
    for centre in np.atleast_2d(guess):
        seeds = correlative_candidates(submap.grid(search), points, centre, window, search)
        refined += [match_scan(submap.reference, points, centre, window, scan_params, start=seed) for seed in seeds]
    refined.sort(key=lambda match: match.objective)
    modes: list = []
    for match in refined:
        if all(
            math.hypot(*(match.pose[:2] - mode.pose[:2])) > params.mode_distance
            or abs(wrap_angle(match.pose[2] - mode.pose[2])) > params.mode_turn
            for mode in modes
        ):
            modes.append(match)
    best = modes[0]
    second = modes[1].objective if len(modes) > 1 else math.inf
    information = match_information(submap.reference, points, best.pose, scan_params)
    covariance = posterior_covariance(information, None, sequential)
    refusal = ""
    if best.overlap < params.min_overlap:
        refusal = "overlap"
    elif best.objective > params.ambiguity_ratio * second:
        refusal = "ambiguous"
    elif math.sqrt(np.linalg.eigvalsh(covariance[:2, :2])[-1]) > params.max_sigma:
        refusal = "degenerate"
    poses = np.array([mode.pose for mode in modes])
    return SubmapMatch(best.pose, covariance, best.overlap, best.objective, second, refusal, poses)


def chain_window(
    cumulative: np.ndarray, path: np.ndarray, anchor: int, query: int, params: ClosureParams
) -> np.ndarray:
    """The search window's covariance (3, 3) between scans ``anchor`` and ``query``, in either order
    (``chain_sigmas`` from the earlier to the later)."""
    first, last = min(anchor, query), max(anchor, query)
    sigma_xy, sigma_th = chain_sigmas(cumulative, path, np.array([first]), last, params)
    return np.diag([sigma_xy[0] ** 2, sigma_xy[0] ** 2, sigma_th[0] ** 2])


def chain_sigmas(
    cumulative: np.ndarray, path: np.ndarray, firsts: np.ndarray, last: int, params: ClosureParams
) -> tuple[np.ndarray, np.ndarray]:
    """The search windows' standard deviations in position (m) and heading (rad), each (N,), between
    each of scans ``firsts`` (N,) and scan ``last``: from ``cumulative`` (S, 2), the sequential
    edges' position (mean of x and y) and heading variances summed from the first scan, and ``path``
    (S,) the path lengths: position variance the summed one plus the heading's spread swinging the
    path between them (``L^2 var_theta / 3``), bounded by ``min_window`` and ``max_window``."""
    position = cumulative[last, 0] - cumulative[firsts, 0]
    heading = cumulative[last, 1] - cumulative[firsts, 1]
    length = path[last] - path[firsts]
    sigma_xy = np.sqrt(np.maximum(position + length**2 * heading / 3.0, 0.0))
    sigma_th = np.sqrt(np.maximum(heading, 0.0))
    sigma_xy = np.minimum(np.maximum(sigma_xy, params.min_window[0]), params.max_window[0])
    sigma_th = np.minimum(np.maximum(sigma_th, params.min_window[1]), params.max_window[1])
    return sigma_xy, sigma_th


def candidate_pairs(
    poses: np.ndarray, keys: np.ndarray, cumulative: np.ndarray, params: ClosureParams
) -> list[tuple[int, int, EdgeKind]]:
    """The (anchor, query, kind) scan pairs to match by the estimate ``poses`` (S, 3), keyframes
    ``keys`` (K,) (module docstring), in a fixed order: by query, local first (behind, then ahead),
    then the nearest visits."""
    path = path_lengths(poses)
    pairs: list[tuple[int, int, EdgeKind]] = []
    key_path = path[keys]
    for n, query in enumerate(keys):
        for step in (*(-back for back in params.local_anchors), *params.local_anchors):
            if 0 <= n + step < len(keys):
                pairs.append((int(keys[n + step]), int(query), EdgeKind.LOCAL))
        far = keys[key_path <= path[query] - params.min_loop_path]
        if not len(far):
            continue
        distance = np.hypot(*(poses[far, :2] - poses[query, :2]).T)
        reach = 3.0 * chain_sigmas(cumulative, path, far, query, params)[0]  # 3 of chain_window's sigmas
        near = distance <= params.search_radius + reach
        if not near.any():
            continue
        # Visits: runs of near keyframes not interrupted by a far one; the nearest of each.
        candidates, gaps = far[near], distance[near]
        runs = np.cumsum(np.concatenate([[1], np.diff(np.flatnonzero(near)) > 1]))
        nearest = [candidates[runs == run][np.argmin(gaps[runs == run])] for run in np.unique(runs)]
        nearest.sort(key=lambda anchor: float(np.hypot(*(poses[anchor, :2] - poses[query, :2]))))
        pairs.extend((int(anchor), int(query), EdgeKind.CLOSURE) for anchor in nearest[: params.closures_per_scan])
    return pairs


def submap_members(anchor: int, query: int, keys: np.ndarray, path: np.ndarray, params: ClosureParams) -> np.ndarray:
    """The keyframes within ``submap_path`` of ``anchor`` along the path and beyond the keyframe
    next to ``query`` on the anchor's side: before the one preceding it for an anchor behind,
    after the one following it for an anchor ahead (so that the query's own neighbourhood is not
    in its submap)."""
    close = np.abs(path[keys] - path[anchor]) <= params.submap_path
    if anchor < query:
        before = keys[keys < query]
        limit = before[-1] if len(before) else query  # the query's preceding keyframe and after: left out
        members = keys[close & (keys < limit)]
    else:
        after = keys[keys > query]
        limit = after[0] if len(after) else query  # the query's following keyframe and before: left out
        members = keys[close & (keys > limit)]
    return members if anchor in members else np.concatenate([members, [anchor]])
