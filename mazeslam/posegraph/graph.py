"""A pose graph: S poses (the nodes) tied by E relative-pose measurements (the edges).

Edge k says that pose ``j[k]`` seen from pose ``i[k]`` is ``measured[k]`` (dx, dy in metres in the
robot frame of pose ``i[k]``, dtheta in radians), with information ``information[k]`` (3, 3), the
inverse of its covariance (1/m^2, 1/(m rad), 1/rad^2). Its residual is the smoother's odometry factor
(``mazeslam.core.least_squares.relative_pose_residual``): ``relative(x_i, x_j) - measured``, heading
wrapped; its squared Mahalanobis length ``r^T Omega r`` is the edge's chi2 (3 degrees of freedom).

Edges are of five kinds (``EdgeKind``): sequential (laser odometry with the wheels as prior between
consecutive scans: always trusted), prior (a motion prior alone between consecutive scans, where
the scans' own match is blind: always trusted), blind (laser odometry between consecutive scans
where the log has no wheel odometry: the scans alone, which a corridor or a turn can fool), local
(a scan matched to the scans just before or after it, the same part of the path) and closure (a
scan matched to scans far back along the path but near in space). Blind, local and closure edges
come from a search that can be fooled, so the solver (``mazeslam.posegraph.solve``) treats them with
a robust kernel.

Every edge but a prior is a scan match, and scan matches on real logs share a heading drift: the
turn they measure from the earlier scan to the later one is off by about the same fraction of a
milliradian per metre between the two scans (experiments/carmen_posegraph/results/match_noise.md),
an error no single edge's covariance states and that hundreds of sequential and local edges add up
along the path. The solver can estimate it as one more unknown, ``drift`` (rad/m): an edge's heading
residual is then ``relative(x_i, x_j)_theta - measured_theta + drift * lever``, with ``lever`` its
signed travel (``PoseGraph.drift_lever``). The loops decide it: a closure spans metres, not the
hundreds of metres of path between its two scans.

World frame x, y in metres, heading in radians wrapped to (-pi, pi]; arrays of poses are (S, 3).
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

import numpy as np
import scipy.sparse

from mazeslam.core.geometry import wrap_angle
from mazeslam.core.least_squares import block_entries, relative_pose_residual


class EdgeKind(enum.IntEnum):
    """Where an edge comes from; all but sequential and prior edges are robust in the solve, all but
    prior edges are scan matches."""

    SEQUENTIAL = 0
    LOCAL = 1
    CLOSURE = 2
    BLIND = 3
    PRIOR = 4


#: The kinds an edge of is always trusted (solved without the robust kernel).
TRUSTED = (EdgeKind.SEQUENTIAL, EdgeKind.PRIOR)


@dataclass(frozen=True)
class PoseGraph:
    """The edges of a pose graph over ``nodes`` poses.

    Attributes:
        nodes: S, the number of poses.
        i, j: (E,) int, the edge's first and second pose (0..S-1, i != j).
        measured: (E, 3) pose j in the frame of pose i: dx, dy (m), dtheta (rad).
        information: (E, 3, 3) inverse covariance of ``measured`` (symmetric positive definite).
        kind: (E,) int, ``EdgeKind`` values.
    """

    nodes: int
    i: np.ndarray
    j: np.ndarray
    measured: np.ndarray
    information: np.ndarray
    kind: np.ndarray

    def __post_init__(self):
        count = len(self.i)
        shapes = (self.j.shape, self.measured.shape, self.information.shape, self.kind.shape)
        if shapes != ((count,), (count, 3), (count, 3, 3), (count,)):
            raise ValueError(f"edge arrays disagree in shape for {count} edges: {shapes}")
        if count and (min(self.i.min(), self.j.min()) < 0 or max(self.i.max(), self.j.max()) >= self.nodes):
            raise ValueError(f"an edge names a pose outside 0..{self.nodes - 1}")
        if np.any(self.i == self.j):
            raise ValueError("an edge ties a pose to itself")

    @classmethod
    def empty(cls, nodes: int) -> PoseGraph:
        """A graph over ``nodes`` poses without edges."""
        return cls(nodes, np.zeros(0, int), np.zeros(0, int), np.zeros((0, 3)), np.zeros((0, 3, 3)), np.zeros(0, int))

    @classmethod
    def of_edges(cls, nodes: int, i, j, measured, covariances, kind) -> PoseGraph:
        """A graph of edges given with covariances (E, 3, 3) rather than information; ``kind`` one
        ``EdgeKind`` for every edge, or one per edge (E,)."""
        covariances = np.asarray(covariances, dtype=float).reshape(-1, 3, 3)
        return cls(
            nodes,
            np.asarray(i, dtype=int).reshape(-1),
            np.asarray(j, dtype=int).reshape(-1),
            np.asarray(measured, dtype=float).reshape(-1, 3),
            np.linalg.inv(covariances) if len(covariances) else np.zeros((0, 3, 3)),
            np.broadcast_to(np.asarray(kind, dtype=int), (len(covariances),)).copy(),
        )

    def __add__(self, other: PoseGraph) -> PoseGraph:
        if other.nodes != self.nodes:
            raise ValueError(f"cannot join graphs over {self.nodes} and {other.nodes} poses")
        return PoseGraph(
            self.nodes,
            np.concatenate([self.i, other.i]),
            np.concatenate([self.j, other.j]),
            np.concatenate([self.measured, other.measured]),
            np.concatenate([self.information, other.information]),
            np.concatenate([self.kind, other.kind]),
        )

    def select(self, keep: np.ndarray) -> PoseGraph:
        """The graph with only the edges where ``keep`` (E,) bool is true."""
        return PoseGraph(
            self.nodes, self.i[keep], self.j[keep], self.measured[keep], self.information[keep], self.kind[keep]
        )

    @property
    def robust(self) -> np.ndarray:
        """(E,) bool: the edge is solved with the robust kernel (all but sequential and prior edges)."""
        return ~np.isin(self.kind, TRUSTED)

    @property
    def drift_lever(self) -> np.ndarray:
        """(E,) m: what the scan matches' heading drift is multiplied by in an edge's heading (module
        docstring): the length of its measured translation, positive when pose j comes after pose
        i, negative when before (the drift is in the turn from the earlier scan to the later); 0 on
        prior edges, which are no match."""
        travel = np.hypot(self.measured[:, 0], self.measured[:, 1]) * np.sign(self.j - self.i)
        return np.where(self.kind == EdgeKind.PRIOR, 0.0, travel)

    def __len__(self) -> int:
        return len(self.i)


def edge_residuals(
    graph: PoseGraph, poses: np.ndarray, drift: float = 0.0
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Residuals (E, 3) ``relative(x_i, x_j) - measured`` (m, m, rad wrapped; frame of pose i) at
    ``poses`` (S, 3), plus ``drift`` (rad/m) times the edge's ``drift_lever`` in the heading, and their
    Jacobians (E, 3, 3) with respect to pose i and pose j."""
    residual, j_from, j_to = relative_pose_residual(poses[graph.i], poses[graph.j], graph.measured)
    if drift:
        residual[:, 2] = wrap_angle(residual[:, 2] + drift * graph.drift_lever)
    return residual, j_from, j_to


def edge_chi2(graph: PoseGraph, poses: np.ndarray, drift: float = 0.0) -> np.ndarray:
    """Each edge's squared Mahalanobis residual ``r^T Omega r`` (E,) at ``poses`` (S, 3) and the
    heading ``drift`` (rad/m)."""
    residual = edge_residuals(graph, poses, drift)[0]
    return np.einsum("ei,eij,ej->e", residual, graph.information, residual)


def whitened_system(
    graph: PoseGraph, poses: np.ndarray, weights: np.ndarray, fixed: int = 0, drift: float | None = None
) -> tuple[np.ndarray, scipy.sparse.csr_array]:
    """The weighted, whitened residual (3E,) and its sparse Jacobian (3E, 3(S-1)) at ``poses``; with
    a heading ``drift`` (rad/m, ``edge_residuals``) to solve for, one more column (3E, 3(S-1) + 1),
    the last, for it.

    Edge k's rows are ``sqrt(weights[k]) W_k r_k`` with ``W_k^T W_k = Omega_k`` (the upper Cholesky
    factor), so that the squared norm is ``sum_k weights[k] chi2_k``. The pose ``fixed`` is held
    (the gauge: a pose graph fixes nothing else); its columns are left out, the others keep their
    order.
    """
    residual, j_from, j_to = edge_residuals(graph, poses, drift or 0.0)
    whitener = np.linalg.cholesky(graph.information).transpose(0, 2, 1) * np.sqrt(weights)[:, None, None]
    column = np.arange(graph.nodes) - (np.arange(graph.nodes) > fixed)  # pose -> its block of columns
    rows = 3 * np.arange(len(graph))
    blocks = []
    for jacobian, pose in ((j_from, graph.i), (j_to, graph.j)):
        free = pose != fixed
        blocks.append(block_entries((whitener @ jacobian)[free], rows[free], 3 * column[pose[free]]))
    if drift is not None:  # d r / d drift = (0, 0, lever)
        by_drift = (whitener[:, :, 2] * graph.drift_lever[:, None])[:, :, None]  # (E, 3, 1)
        blocks.append(block_entries(by_drift, rows, np.full(len(graph), 3 * (graph.nodes - 1))))
    rows_, columns, values = (np.concatenate(parts) for parts in zip(*blocks))
    shape = (3 * len(graph), 3 * (graph.nodes - 1) + (drift is not None))
    jacobian = scipy.sparse.csr_array((values, (rows_, columns)), shape=shape)
    return np.einsum("eij,ej->ei", whitener, residual).ravel(), jacobian
