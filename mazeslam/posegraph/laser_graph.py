"""The pose graph of a laser log: every scan a node, the laser odometry between consecutive scans,
local and loop-closure matches between keyframes, solved robustly; closures re-detected from the
improved estimate a few times.

1. Sequential edges: the laser odometry with each interval's match covariance
   (``mazeslam.posegraph.sequential``). Their chain from the log's start pose is the first estimate;
   on a log without any wheel odometry (``PoseGraphParams.grid_start``) the grid filter's best path
   (``mazeslam.gridslam``, the config's ``[grid]``) is. A blind match (no wheel odometry) that the
   ambiguity test finds ambiguous is left out (``ambiguous_intervals``) and its modes kept: a
   match between two scans that such a step separates is searched around the estimate's relative
   pose and around the one each mode of the step gives (``guesses``), so that the ambiguity test
   refuses it where the submap cannot tell the modes apart instead of confirming whichever the
   estimate took.
2. Each pass: the keyframes' local and closure pairs by the current estimate
   (``mazeslam.posegraph.closures.candidate_pairs``) not tried before are matched; the accepted ones
   join the graph, which is solved (``mazeslam.posegraph.solve.solve_graph``: Geman-McClure on the
   matched edges, graduated non-convexity). A pass that finds no new edge ends the loop.
   Each solve also estimates the scan matches' heading drift (rad/m, ``mazeslam.posegraph.graph``),
   which the loops decide and which would otherwise bend the path by the sequential and local
   edges' shared error.
3. The last solve's poses and covariances (relative to the first scan) are the result.

Deterministic: no random draws; pairs are tried in a fixed order.
"""

from __future__ import annotations

import dataclasses
import time
from collections import OrderedDict
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from mazeslam.core.geometry import compose, relative
from mazeslam.posegraph.closures import (
    Submap,
    build_submap,
    candidate_pairs,
    chain_window,
    keyframes,
    match_to_submap,
    path_lengths,
    submap_members,
)
from mazeslam.posegraph.graph import EdgeKind, PoseGraph
from mazeslam.posegraph.params import PoseGraphParams
from mazeslam.posegraph.sequential import sequential_odometry
from mazeslam.posegraph.solve import GraphSolution, solve_graph
from mazeslam.registration.scan_matching import ReferenceScan, ScanMatchParams, scan_points

#: Submaps kept for reuse while the pairs are matched (in order of the query: consecutive queries
#: reuse their anchors' submaps); each holds its likelihood grids, up to a few MB.
SUBMAP_CACHE = 32

if TYPE_CHECKING:
    from mazeslam.data.loaded_run import LoadedRun
    from mazeslam.pipeline.config import SlamConfig


@dataclass(frozen=True)
class PoseGraphResult:
    """The solved pose graph of a log.

    Attributes:
        scan_records: (S,) the log's record index of each scan (node).
        poses: (S, 3) world frame (the first scan where the laser odometry puts it from the log's
            start pose), m and rad; covariances (S, 3, 3) in the world frame: the graph's relative
            to the first scan and the first scan's own from the start pose
            (``with_first_pose_uncertainty``).
        odometry_poses: (S, 3) the laser odometry chained from the log's start pose: the first
            estimate, except on a log without wheel odometry, whose first estimate is the grid
            filter's path (``PoseGraphParams.grid_start``).
        graph: every edge; solution: the final solve (``kept`` says which robust edges it kept).
        tried, accepted: per ``EdgeKind`` name ("local", "closure"), matches tried and accepted by
            the ambiguity test; refused: per reason ("overlap", "ambiguous", "degenerate", and
            "empty": a submap or query with too few points to match).
        passes: detection and solve rounds run; pass_seconds: per pass (matching seconds, solve
            seconds, edges found), the last the final solve with covariances; seconds: wall-clock
            seconds of the whole build.
    """

    scan_records: np.ndarray
    poses: np.ndarray
    covariances: np.ndarray
    odometry_poses: np.ndarray
    graph: PoseGraph
    solution: GraphSolution
    tried: dict
    accepted: dict
    refused: dict
    passes: int
    pass_seconds: list
    seconds: float

    def kept(self, kind: EdgeKind) -> int:
        """Edges of ``kind`` the robust solve kept."""
        return int(np.sum(self.solution.kept & (self.graph.kind == kind)))

    def rejected(self, kind: EdgeKind) -> int:
        """Edges of ``kind`` accepted by the match but dropped by the robust solve."""
        return int(np.sum(~self.solution.kept & (self.graph.kind == kind)))

    @property
    def chi2_per_dof(self) -> float:
        return self.solution.chi2_per_dof


def sequential_graph(
    increments: np.ndarray,
    covariances: np.ndarray,
    blind: np.ndarray | None = None,
    priors: np.ndarray | None = None,
    prior_covariances: np.ndarray | None = None,
) -> PoseGraph:
    """The chain of edges k-1 -> k (k = 1..S-1) from ``increments`` (S, 3) and ``covariances``
    (S, 3, 3) (index 0, from the start pose, is not an edge: the first pose is held).

    Where ``blind`` (S,) bool (no wheel odometry for the interval), the match is a robust
    ``EdgeKind.BLIND`` edge, and the match's motion prior (``priors`` (S, 3), ``prior_covariances``
    (S, 3, 3): constant velocity, broad) an ``EdgeKind.PRIOR`` edge beside it, trusted, so that the
    chain stays connected where the robust solve drops the match."""
    count = len(increments)
    nodes = np.arange(1, count)
    blind = np.zeros(count, bool) if blind is None else np.asarray(blind, bool)
    kinds = np.where(blind[1:], int(EdgeKind.BLIND), int(EdgeKind.SEQUENTIAL))
    graph = PoseGraph.of_edges(count, nodes - 1, nodes, increments[1:], covariances[1:], kinds)
    if blind[1:].any():
        assert priors is not None and prior_covariances is not None
        where = nodes[blind[1:]]
        graph = graph + PoseGraph.of_edges(
            count, where - 1, where, priors[where], prior_covariances[where], EdgeKind.PRIOR
        )
    return graph


def laser_pose_graph(run: LoadedRun, config: SlamConfig, params: PoseGraphParams | None = None) -> PoseGraphResult:
    """The pose graph of ``run``'s scans with ``config``'s ``[scan_matching]`` laser odometry."""
    began = time.perf_counter()
    params = params or PoseGraphParams()
    scan_params = config.scan_matching
    odometry, covariances = sequential_odometry(run.log, run.geometry, scan_params, params.sequential)
    chain = odometry.poses(run.start_pose)
    points = [scan_points(run.log.values[record], run.geometry, scan_params) for record in odometry.scan_records]
    priors, prior_covariances = odometry.priors(scan_params)  # a blind interval's: constant velocity
    blind = ~odometry.had_odometry
    blind[0] = False
    sequential = sequential_graph(odometry.increments, covariances, blind, priors, prior_covariances)
    ambiguous, modes = ambiguous_intervals(points, odometry.increments, prior_covariances, blind, scan_params, params)
    if ambiguous.any():  # the blind edges are the first S - 1; their constant-velocity priors stay
        priors_kept = np.ones(len(sequential) - len(chain) + 1, bool)
        sequential = sequential.select(np.concatenate([~ambiguous[1:], priors_kept]))
    initial = chain
    if params.grid_start and len(chain) > 1 and blind[1:].all():
        # No wheel odometry at all: the grid filter's best path is the first estimate.
        initial = grid_filter_path(run, config, odometry.scan_records)
    result = solve_laser_graph(
        odometry.scan_records, chain, sequential, covariances, points, scan_params, params, began, initial, modes
    )
    return dataclasses.replace(
        result, covariances=with_first_pose_uncertainty(result.poses, result.covariances, covariances[0])
    )


def ambiguous_intervals(
    points: list[np.ndarray],
    increments: np.ndarray,
    prior_covariances: np.ndarray,
    blind: np.ndarray,
    scan_params: ScanMatchParams,
    params: PoseGraphParams,
) -> tuple[np.ndarray, dict[int, np.ndarray]]:
    """(S,) bool: the blind interval's match (scan k to scan k-1, ``increments[k]``) has a second
    mode as good, by the local matches' ambiguity test (``match_to_submap`` against scan k-1 alone,
    within its motion prior's ``prior_covariances[k]`` bounded by ``max_window``; overlap not
    required); and for each such k its modes, the increments (M, 3) the scan-to-scan match cannot
    tell apart. Along a corridor a blind scan-to-scan match can sit metres off with as good an
    objective (orebro: the test finds the intervals 17, 28, 36, 213, 216, 221 and 227 that
    experiments/carmen_grid/results/orebro_checks.md finds metres or a right angle wrong, among 25
    of 236); such an edge is left out, its constant-velocity prior and the local matches place the
    scan, and the matches across it are searched around each of its modes (``guesses``)."""
    closure = dataclasses.replace(params.closures, min_overlap=0.0)
    found = np.zeros(len(increments), bool)
    modes: dict[int, np.ndarray] = {}
    for k in np.flatnonzero(blind):
        if k == 0 or len(points[k - 1]) < max(scan_params.neighbours, 10) or len(points[k]) < scan_params.neighbours:
            continue
        submap = Submap(points[k - 1], ReferenceScan(points[k - 1], scan_params))
        sigma = np.sqrt(np.diag(prior_covariances[k]))
        xy, turn = min(sigma[0], closure.max_window[0]), min(sigma[2], closure.max_window[1])
        window = np.diag([xy**2, xy**2, turn**2])
        match = match_to_submap(submap, points[k], increments[k], window, closure, scan_params, params.sequential)
        found[k] = match.refusal == "ambiguous"
        if found[k]:
            modes[int(k)] = match.modes
    return found, modes


def guesses(poses: np.ndarray, anchor: int, query: int, modes: dict[int, np.ndarray]) -> np.ndarray:
    """The pose of scan ``query`` in scan ``anchor``'s frame (G, 3): by the estimate ``poses``
    (S, 3) first, then, for each ambiguous interval k between the two (``modes``: k -> the
    increments (M, 3) its scan-to-scan match cannot tell apart), with the step from scan k-1 to k
    replaced by each of its modes (the scans from k on moved with it)."""
    found = [relative(poses[anchor], poses[query])]
    first, last = min(anchor, query), max(anchor, query)
    for k, increments in modes.items():
        if not first < k <= last:
            continue
        for increment in increments:
            moved = compose(poses[k - 1], increment)
            placed = [poses[j] if j < k else compose(moved, relative(poses[k], poses[j])) for j in (anchor, query)]
            found.append(relative(placed[0], placed[1]))
    return np.array(found)


def grid_filter_path(run: LoadedRun, config: SlamConfig, scan_records: np.ndarray) -> np.ndarray:
    """The grid filter's final best path (S, 3) at ``scan_records`` with ``config``'s settings for it
    (``SlamConfig.grid_filter``, as ``mazeslam slam`` runs it): the first estimate of a log without odometry."""
    from mazeslam.gridslam.filter import run_grid_slam

    params = config.grid_filter
    grid = run_grid_slam(run.log, run.geometry, run.start_pose, params, sensor_max_range=run.sensor_max_range)
    where = np.searchsorted(grid.scan_records, scan_records)
    assert np.array_equal(grid.scan_records[where], scan_records)
    return grid.best_poses[where]


def with_first_pose_uncertainty(poses: np.ndarray, covariances: np.ndarray, first: np.ndarray) -> np.ndarray:
    """Covariances (S, 3, 3) of ``poses`` (S, 3) in the world frame from those relative to the first
    pose (``covariances``, the solve's, zero at the first) and the first pose's own covariance
    ``first`` (3, 3) (the motion from the log's start pose to the first scan, which no edge
    constrains): ``A_k first A_k^T + covariances[k]``, A_k the Jacobian of pose k with respect to
    the first pose when the graph moves with it rigidly (a heading error at the first pose swings
    every later pose about it)."""
    lever = poses[:, :2] - poses[0, :2]
    jacobian = np.tile(np.eye(3), (len(poses), 1, 1))
    jacobian[:, 0, 2], jacobian[:, 1, 2] = -lever[:, 1], lever[:, 0]
    return jacobian @ first @ jacobian.transpose(0, 2, 1) + covariances


def solve_laser_graph(
    scan_records: np.ndarray,
    chain: np.ndarray,
    sequential: PoseGraph,
    covariances: np.ndarray,
    points: list[np.ndarray],
    scan_params: ScanMatchParams,
    params: PoseGraphParams,
    began: float | None = None,
    initial: np.ndarray | None = None,
    ambiguous_modes: dict[int, np.ndarray] | None = None,
) -> PoseGraphResult:
    """Steps 2-3 of the module docstring from the sequential edges: ``chain`` (S, 3) the chained
    poses, ``sequential`` their graph, ``covariances`` (S, 3, 3) the intervals' (index k: from scan
    k-1 to k; index 0 unused), which set the search windows, ``points`` the S scans' returns (K_s, 2)
    in their robot frames, ``ambiguous_modes`` the blind intervals left out as ambiguous with their
    modes (``ambiguous_intervals``)."""
    ambiguous_modes = ambiguous_modes or {}
    began = time.perf_counter() if began is None else began
    graph = sequential
    poses = (chain if initial is None else initial).copy()
    variances = np.column_stack([0.5 * (covariances[:, 0, 0] + covariances[:, 1, 1]), covariances[:, 2, 2]])
    variances[0] = 0.0
    cumulative = np.cumsum(variances, axis=0)
    keys = keyframes(poses, params.closures.keyframe_distance, params.closures.keyframe_turn)
    tried_pairs: set[tuple[int, int]] = set()
    tried = {"local": 0, "closure": 0}
    accepted = {"local": 0, "closure": 0}
    refused = {"overlap": 0, "ambiguous": 0, "degenerate": 0, "empty": 0}
    solution, passes, timings, drift = None, 0, [], 0.0
    for _ in range(params.passes):
        passes += 1
        started = time.perf_counter()
        found = _matched_edges(
            poses, keys, cumulative, points, scan_params, params, ambiguous_modes, tried_pairs, tried, accepted, refused
        )
        graph = graph + found
        if solution is not None and not len(found):
            break
        matched = time.perf_counter()
        solution = solve_graph(graph, poses, params.solve, covariances=False, drift=drift)
        poses, drift = solution.poses, solution.drift
        timings.append((matched - started, time.perf_counter() - matched, len(found)))
    started = time.perf_counter()
    solution = solve_graph(graph, poses, params.solve, covariances=True, drift=drift)
    timings.append((0.0, time.perf_counter() - started, 0))
    assert solution.covariances is not None
    return PoseGraphResult(
        scan_records=np.asarray(scan_records),
        poses=solution.poses,
        covariances=solution.covariances,
        odometry_poses=chain,
        graph=graph,
        solution=solution,
        tried=tried,
        accepted=accepted,
        refused=refused,
        passes=passes,
        pass_seconds=timings,
        seconds=time.perf_counter() - began,
    )


def _matched_edges(
    poses: np.ndarray,
    keys: np.ndarray,
    cumulative: np.ndarray,
    points: list[np.ndarray],
    scan_params: ScanMatchParams,
    params: PoseGraphParams,
    ambiguous_modes: dict[int, np.ndarray],
    tried_pairs: set,
    tried: dict,
    accepted: dict,
    refused: dict,
) -> PoseGraph:
    """The accepted matches of the pairs not tried before, as edges (anchor -> query); counts updated."""
    closure = params.closures
    path = path_lengths(poses)
    submaps: OrderedDict = OrderedDict()  # the most recently used, oldest first
    anchors, queries, measured, covariances, kinds = [], [], [], [], []
    for anchor, query, kind in candidate_pairs(poses, keys, cumulative, closure):
        if (anchor, query) in tried_pairs:
            continue
        tried_pairs.add((anchor, query))
        name = "local" if kind == EdgeKind.LOCAL else "closure"
        tried[name] += 1
        members = submap_members(anchor, query, keys, path, closure)
        key = (anchor, tuple(members))
        if key not in submaps:
            submaps[key] = build_submap(anchor, members, poses, points, closure, scan_params)
            if len(submaps) > SUBMAP_CACHE:
                submaps.popitem(last=False)
        submaps.move_to_end(key)
        submap = submaps[key]
        if submap is None or len(points[query]) < scan_params.neighbours:
            refused["empty"] += 1
            continue
        guess = guesses(poses, anchor, query, ambiguous_modes)
        window = chain_window(cumulative, path, anchor, query, closure)
        match = match_to_submap(submap, points[query], guess, window, closure, scan_params, params.sequential)
        if not match.accepted:
            refused[match.refusal] += 1
            continue
        accepted[name] += 1
        anchors.append(anchor)
        queries.append(query)
        measured.append(match.pose)
        covariances.append(match.covariance)
        kinds.append(int(kind))
    return PoseGraph.of_edges(len(poses), anchors, queries, measured, covariances, np.asarray(kinds, dtype=int))
