"""A pose graph: S poses (the nodes) tied by E relative-pose measurements (the edges).

Edge k says that pose ``j[k]`` seen from pose ``i[k]`` is ``measured[k]`` (dx, dy in metres in the
robot frame of pose ``i[k]``, dtheta in radians), with information ``information[k]`` (3, 3), the
inverse of its covariance (1/m^2, 1/(m rad), 1/rad^2). Its residual is the smoother's odometry factor
(``mazeslam.core.least_squares.relative_pose_residual``): ``relative(x_i, x_j) - measured``, heading
wrapped; its squared Mahalanobis length ``r^T Omega r`` is the edge's chi2 (3 degrees of freedom).

Edges are of four kinds (``EdgeKind``): sequential (laser odometry with the wheels as prior between
consecutive scans, or a motion prior alone: always trusted), blind (laser odometry between
consecutive scans where the log has no wheel odometry: the scans alone, which a corridor or a turn
can fool), local (a scan matched to the scans just before or after it, the same part of the path) and closure
(a scan matched to scans far back along the path but near in space). Blind, local and closure edges
come from a search that can be fooled, so the solver (``mazeslam.posegraph.solve``) treats them with
a robust kernel.

World frame x, y in metres, heading in radians wrapped to (-pi, pi]; arrays of poses are (S, 3).
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

import numpy as np
import scipy.sparse

from mazeslam.core.least_squares import block_entries, relative_pose_residual


class EdgeKind(enum.IntEnum):
    """Where an edge comes from; all but sequential edges are robust in the solve."""

    SEQUENTIAL = 0
    LOCAL = 1
    CLOSURE = 2
    BLIND = 3


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
        """(E,) bool: the edge is solved with the robust kernel (all but sequential edges)."""
        return self.kind != EdgeKind.SEQUENTIAL

    def __len__(self) -> int:
        return len(self.i)


def edge_residuals(graph: PoseGraph, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Residuals (E, 3) ``relative(x_i, x_j) - measured`` (m, m, rad wrapped; frame of pose i) at
    ``poses`` (S, 3) and their Jacobians (E, 3, 3) with respect to pose i and pose j."""
    return relative_pose_residual(poses[graph.i], poses[graph.j], graph.measured)


def edge_chi2(graph: PoseGraph, poses: np.ndarray) -> np.ndarray:
    """Each edge's squared Mahalanobis residual ``r^T Omega r`` (E,) at ``poses`` (S, 3)."""
    residual = edge_residuals(graph, poses)[0]
    return np.einsum("ei,eij,ej->e", residual, graph.information, residual)


def whitened_system(
    graph: PoseGraph, poses: np.ndarray, weights: np.ndarray, fixed: int = 0
) -> tuple[np.ndarray, scipy.sparse.csr_array]:
    """The weighted, whitened residual (3E,) and its sparse Jacobian (3E, 3(S-1)) at ``poses``.

    Edge k's rows are ``sqrt(weights[k]) W_k r_k`` with ``W_k^T W_k = Omega_k`` (the upper Cholesky
    factor), so that the squared norm is ``sum_k weights[k] chi2_k``. The pose ``fixed`` is held
    (the gauge: a pose graph fixes nothing else); its columns are left out, the others keep their
    order.
    """
    residual, j_from, j_to = edge_residuals(graph, poses)
    whitener = np.linalg.cholesky(graph.information).transpose(0, 2, 1) * np.sqrt(weights)[:, None, None]
    column = np.arange(graph.nodes) - (np.arange(graph.nodes) > fixed)  # pose -> its block of columns
    rows = 3 * np.arange(len(graph))
    blocks = []
    for jacobian, pose in ((j_from, graph.i), (j_to, graph.j)):
        free = pose != fixed
        blocks.append(block_entries((whitener @ jacobian)[free], rows[free], 3 * column[pose[free]]))
    rows_, columns, values = (np.concatenate(parts) for parts in zip(*blocks))
    shape = (3 * len(graph), 3 * (graph.nodes - 1))
    jacobian = scipy.sparse.csr_array((values, (rows_, columns)), shape=shape)
    return np.einsum("eij,ej->ei", whitener, residual).ravel(), jacobian
