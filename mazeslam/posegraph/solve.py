"""The robust sparse least-squares solve of a pose graph.

Minimises ``sum_k rho_k(chi2_k)`` over the poses, chi2_k the edge's squared Mahalanobis residual
(``mazeslam.posegraph.graph``): ``rho(c) = c`` for sequential edges, the Geman-McClure kernel
``rho(c) = Phi c / (Phi + c)`` for local and closure edges. Geman-McClure is what switchable
constraints (Sünderhauf and Protzel 2012) become with the switch solved in closed form: an edge
that disagrees with the rest of the graph by far more than ``Phi`` costs at most ``Phi`` and
pulls on nothing, so one false closure cannot fold the map.

The kernel is not convex, so the solve starts convex and narrows (graduated non-convexity, Yang et
al. 2020): ``rho_mu(c) = mu Phi c / (mu Phi + c)`` from a ``mu`` at which every edge is inside the
quadratic part, divided by ``gnc_factor`` until 1. Each step is Levenberg-Marquardt on iteratively
reweighted least squares: weights ``(mu Phi / (mu Phi + c))^2`` from the current residuals, the
damped normal equations ``(J^T J + lambda diag(J^T J)) delta = -J^T r`` solved sparse (SuperLU),
the step kept when the robust cost falls.

Then each robust edge is kept when its chi2 is at most ``Phi`` (its weight at least 1/4), and the
graph of the kept edges is solved without a kernel, so that chi2/dof and the covariances at the
optimum (the diagonal blocks of ``(J^T J)^-1``, the Laplace approximation) are those of a Gaussian
problem. The first pose is held fixed (the gauge): covariances are relative to it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse
import scipy.sparse.linalg

from mazeslam.core.geometry import wrap_angle
from mazeslam.posegraph.graph import PoseGraph, edge_chi2, whitened_system
from mazeslam.posegraph.params import SolveParams


@dataclass(frozen=True)
class GraphSolution:
    """A solved pose graph.

    Attributes:
        poses: (S, 3) world frame, m and rad; pose 0 as given.
        covariances: (S, 3, 3) marginal covariance of each pose relative to pose 0 (zero for pose
            0), m^2, m rad, rad^2; None when not asked for.
        kept: (E,) bool, the edge is in the final solve (sequential edges always; robust edges when
            their chi2 at the robust optimum is at most ``kernel_chi2``).
        edge_chi2: (E,) each edge's chi2 at the final poses.
        chi2: the kept edges' summed chi2; dof: their residual dimensions minus the unknowns.
        iterations: linear solves made, robust and final.
        converged: the final solve's last step moved no pose by more than ``step_tolerance``.
    """

    poses: np.ndarray
    covariances: np.ndarray | None
    kept: np.ndarray
    edge_chi2: np.ndarray
    chi2: float
    dof: int
    iterations: int
    converged: bool

    @property
    def chi2_per_dof(self) -> float:
        return self.chi2 / self.dof if self.dof > 0 else float("nan")


def _weights(chi2: np.ndarray, robust: np.ndarray, scale: float) -> np.ndarray:
    """IRLS weights (E,): 1 on plain edges, ``(scale / (scale + chi2))^2`` on robust ones."""
    return np.where(robust, (scale / (scale + chi2)) ** 2, 1.0)


def _cost(chi2: np.ndarray, robust: np.ndarray, scale: float) -> float:
    """The robust cost: chi2 on plain edges, ``scale chi2 / (scale + chi2)`` on robust ones."""
    return float(np.sum(np.where(robust, scale * chi2 / (scale + chi2), chi2)))


def _moved(poses: np.ndarray, step: np.ndarray, fixed: int) -> np.ndarray:
    """Poses (S, 3) moved by a step (3(S-1),) over every pose but ``fixed``, headings wrapped."""
    moved = poses.copy()
    free = np.arange(len(poses)) != fixed
    moved[free] += step.reshape(-1, 3)
    moved[:, 2] = wrap_angle(moved[:, 2])
    return moved


def _levenberg_marquardt(
    graph: PoseGraph, poses: np.ndarray, scale: float, iterations: int, tolerance: float, fixed: int
) -> tuple[np.ndarray, int, bool]:
    """Up to ``iterations`` reweighted LM steps on the cost with kernel scale ``scale`` (inf: no
    kernel). Returns the poses, the linear solves made and whether the last step was below
    ``tolerance``."""
    robust = graph.robust & np.isfinite(scale)
    chi2 = edge_chi2(graph, poses)
    cost = _cost(chi2, robust, scale) if np.isfinite(scale) else float(chi2.sum())
    damping, solves, converged = 1e-6, 0, False
    while solves < iterations and not converged:
        weights = _weights(chi2, robust, scale) if np.isfinite(scale) else np.ones(len(graph))
        residual, jacobian = whitened_system(graph, poses, weights, fixed)
        information = (jacobian.T @ jacobian).tocsc()
        gradient = jacobian.T @ residual
        while True:
            damped = information + damping * scipy.sparse.diags_array(information.diagonal() + 1e-12)
            step = scipy.sparse.linalg.spsolve(damped, -gradient)
            solves += 1
            candidate = _moved(poses, step, fixed)
            new_chi2 = edge_chi2(graph, candidate)
            new_cost = _cost(new_chi2, robust, scale) if np.isfinite(scale) else float(new_chi2.sum())
            converged = float(np.abs(step).max(initial=0.0)) <= tolerance
            if new_cost <= cost:
                poses, chi2, cost = candidate, new_chi2, new_cost
                damping = max(damping / 10, 1e-12)
                break
            if converged or solves >= iterations:
                break
            damping *= 10
    return poses, solves, converged


def solve_graph(
    graph: PoseGraph, initial: np.ndarray, params: SolveParams | None = None, covariances: bool = True
) -> GraphSolution:
    """The robust optimum of ``graph`` from ``initial`` poses (S, 3), pose 0 held (module docstring)."""
    params = params or SolveParams()
    poses = np.array(initial, dtype=float)
    phi = params.kernel_chi2
    if graph.nodes < 2:  # one pose, held: nothing to solve
        zeros = np.zeros((graph.nodes, 3, 3)) if covariances else None
        return GraphSolution(poses, zeros, np.ones(len(graph), bool), np.zeros(len(graph)), 0.0, 0, 0, True)
    # 1. Graduated non-convexity on the robust edges: start where every edge is quadratic.
    robust = graph.robust
    solves = 0
    poses, solves, _ = _levenberg_marquardt(graph, poses, np.inf, params.max_iterations, params.step_tolerance, 0)
    if robust.any():
        mu = max(1.0, float(edge_chi2(graph, poses)[robust].max()) / phi)
        while True:
            last = mu <= 1.0
            count = params.max_iterations if last else params.gnc_iterations
            poses, made, _ = _levenberg_marquardt(graph, poses, mu * phi, count, params.step_tolerance, 0)
            solves += made
            if last:
                break
            mu = max(1.0, mu / params.gnc_factor)
    # 2. Keep the robust edges that fit; solve the kept graph as a Gaussian problem.
    kept = ~robust | (edge_chi2(graph, poses) <= phi)
    final = graph.select(kept)
    poses, made, converged = _levenberg_marquardt(final, poses, np.inf, params.max_iterations, params.step_tolerance, 0)
    solves += made
    chi2 = edge_chi2(graph, poses)
    residual, jacobian = whitened_system(final, poses, np.ones(len(final)), 0)
    pose_covariances = None
    if covariances:
        pose_covariances = np.zeros((graph.nodes, 3, 3))
        pose_covariances[1:] = marginal_covariances((jacobian.T @ jacobian).tocsc())
    return GraphSolution(
        poses=poses,
        covariances=pose_covariances,
        kept=kept,
        edge_chi2=chi2,
        chi2=float(chi2[kept].sum()),
        dof=3 * len(final) - 3 * (graph.nodes - 1),
        iterations=solves,
        converged=converged,
    )


def robust_cost(graph: PoseGraph, poses: np.ndarray, params: SolveParams | None = None) -> float:
    """The cost ``solve_graph`` minimises, at ``poses`` (S, 3), with the kernel at its final width:
    ``sum_k rho_k(chi2_k)`` (module docstring). Two solutions of one graph compare by it."""
    params = params or SolveParams()
    return _cost(edge_chi2(graph, poses), graph.robust, params.kernel_chi2)


def marginal_covariances(information: scipy.sparse.csc_array, chunk: int = 128) -> np.ndarray:
    """The diagonal 3 x 3 blocks (n, 3, 3) of the inverse of a sparse information matrix (3n, 3n).

    One sparse LU factorisation, then solves for ``chunk`` poses' unit columns at a time: memory
    O(3n x 3 chunk), never the dense inverse.
    """
    size = information.shape[0]
    lu = scipy.sparse.linalg.splu(information)
    count = size // 3
    blocks = np.empty((count, 3, 3))
    for first in range(0, count, chunk):
        last = min(count, first + chunk)
        columns = np.zeros((size, 3 * (last - first)))
        columns[3 * first : 3 * last, :] = np.eye(3 * (last - first))
        solved = lu.solve(columns)[3 * first : 3 * last]  # (3m, 3m): the needed rows
        part = solved.reshape(last - first, 3, last - first, 3)
        blocks[first:last] = part[np.arange(last - first), :, np.arange(last - first), :]
    return 0.5 * (blocks + blocks.transpose(0, 2, 1))
