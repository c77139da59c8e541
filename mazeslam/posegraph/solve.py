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

With ``drift_sigma`` above 0 the scan matches' heading drift (rad/m, ``mazeslam.posegraph.graph``)
is one more unknown, under a zero-mean Gaussian prior of that standard deviation, the term
``(drift / drift_sigma)^2`` added to the cost: the loops fix it where there are loops, the prior
where there are none. The poses' covariances then include its uncertainty.
"""

from __future__ import annotations

import math
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
        kept: (E,) bool, the edge is in the final solve (sequential and prior edges always; robust
            edges when their chi2 at the robust optimum is at most ``kernel_chi2``).
        edge_chi2: (E,) each edge's chi2 at the final poses.
        chi2: the kept edges' summed chi2; dof: their residual dimensions minus the unknowns (the
            drift's prior counted as a residual).
        iterations: linear solves made, robust and final.
        converged: the final solve's last step moved no pose by more than ``step_tolerance``.
        drift: the scan matches' heading drift, rad/m (0 when not estimated); drift_sigma its
            standard deviation (0: not estimated; with no loop, about the prior's).
    """

    poses: np.ndarray
    covariances: np.ndarray | None
    kept: np.ndarray
    edge_chi2: np.ndarray
    chi2: float
    dof: int
    iterations: int
    converged: bool
    drift: float = 0.0
    drift_sigma: float = 0.0

    @property
    def chi2_per_dof(self) -> float:
        return self.chi2 / self.dof if self.dof > 0 else float("nan")


@dataclass(frozen=True)
class _State:
    """What the solve moves: the poses (S, 3) and the heading drift (rad/m)."""

    poses: np.ndarray
    drift: float


def _weights(chi2: np.ndarray, robust: np.ndarray, scale: float) -> np.ndarray:
    """IRLS weights (E,): 1 on plain edges, ``(scale / (scale + chi2))^2`` on robust ones."""
    return np.where(robust, (scale / (scale + chi2)) ** 2, 1.0) if np.isfinite(scale) else np.ones(len(chi2))


def _cost(chi2: np.ndarray, robust: np.ndarray, scale: float) -> float:
    """The robust cost of the edges: chi2 on plain edges, ``scale chi2 / (scale + chi2)`` on robust ones."""
    if not np.isfinite(scale):
        return float(chi2.sum())
    return float(np.sum(np.where(robust, scale * chi2 / (scale + chi2), chi2)))


def _moved(state: _State, step: np.ndarray) -> _State:
    """``state`` moved by a step over every pose but pose 0 (3(S-1),), headings wrapped, or over
    them and the drift (3(S-1) + 1,)."""
    moved = state.poses.copy()
    unknowns = 3 * (len(moved) - 1)
    moved[1:] += step[:unknowns].reshape(-1, 3)
    moved[:, 2] = wrap_angle(moved[:, 2])
    return _State(moved, state.drift + (float(step[unknowns]) if len(step) > unknowns else 0.0))


def _drift_prior_cost(drift: float, drift_sigma: float) -> float:
    """The drift's prior term of the cost, ``(drift / drift_sigma)^2`` (0 when it is not estimated)."""
    return (drift / drift_sigma) ** 2 if drift_sigma > 0 else 0.0


def _levenberg_marquardt(
    graph: PoseGraph, state: _State, scale: float, iterations: int, tolerance: float, drift_sigma: float
) -> tuple[_State, int, bool]:
    """Up to ``iterations`` reweighted LM steps on the cost with kernel scale ``scale`` (inf: no
    kernel), pose 0 held, the drift solved for under its prior when ``drift_sigma`` > 0. Returns the
    state, the linear solves made and whether the last step was below ``tolerance``."""
    robust = graph.robust & np.isfinite(scale)
    estimated = drift_sigma > 0
    prior = 1.0 / drift_sigma**2 if estimated else 0.0

    def cost(chi2: np.ndarray, drift: float) -> float:
        return _cost(chi2, robust, scale) + _drift_prior_cost(drift, drift_sigma)

    chi2 = edge_chi2(graph, state.poses, state.drift)
    current = cost(chi2, state.drift)
    damping, solves, converged = 1e-6, 0, False
    while solves < iterations and not converged:
        residual, jacobian = whitened_system(
            graph, state.poses, _weights(chi2, robust, scale), 0, state.drift if estimated else None
        )
        information = (jacobian.T @ jacobian).tocsc()
        gradient = jacobian.T @ residual
        if estimated:  # the drift's prior: the last unknown
            gradient[-1] += prior * state.drift
        while True:
            step = _damped_step(information, gradient, damping, prior if estimated else None)
            solves += 1
            candidate = _moved(state, step)
            new_chi2 = edge_chi2(graph, candidate.poses, candidate.drift)
            new_cost = cost(new_chi2, candidate.drift)
            converged = float(np.abs(step).max(initial=0.0)) <= tolerance
            if new_cost <= current:
                state, chi2, current = candidate, new_chi2, new_cost
                damping = max(damping / 10, 1e-12)
                break
            if converged or solves >= iterations:
                break
            damping *= 10
    return state, solves, converged


def _damped_step(
    information: scipy.sparse.csc_array, gradient: np.ndarray, damping: float, drift_prior: float | None
) -> np.ndarray:
    """The LM step ``-(H + damping diag(H))^-1 gradient`` for the information ``H`` (n, n) and the
    gradient (n,). With the drift (``drift_prior``: its prior's information, 1/drift_sigma^2), the last
    unknown is the drift, whose row and column are dense (every match edge's heading depends on
    it): solved by the Schur complement on it (``_bordered``), so that the sparse factorisation is
    the poses' alone and fills in no more than without the drift."""
    if drift_prior is None:
        damped = information + damping * scipy.sparse.diags_array(information.diagonal() + 1e-12)
        return scipy.sparse.linalg.spsolve(damped, -gradient)
    poses, coupling, corner = _blocks(information, drift_prior)
    damped = poses + damping * scipy.sparse.diags_array(poses.diagonal() + 1e-12)
    return _bordered(damped.tocsc(), coupling, corner * (1 + damping) + 1e-12 * damping, -gradient)[0]


def _blocks(
    information: scipy.sparse.csc_array, drift_prior: float
) -> tuple[scipy.sparse.csc_array, np.ndarray, float]:
    """The poses' block (n-1, n-1), the poses-drift column (n-1,) and the drift's own information
    (its prior's added) of an information matrix (n, n) whose last unknown is the drift."""
    last = information.shape[0] - 1
    column = information[:, [last]].toarray().ravel()
    return information[:last, :last].tocsc(), column[:last], float(column[last]) + drift_prior


def _bordered(
    poses: scipy.sparse.csc_array, coupling: np.ndarray, corner: float, right: np.ndarray
) -> tuple[np.ndarray, np.ndarray, float]:
    """The solution (n,) of ``[[A, b], [b^T, c]] x = right`` for the sparse ``A`` (n-1, n-1), the
    dense ``b`` (n-1,) and the scalar ``c``, by one factorisation of ``A``: ``A^-1 b`` and the
    Schur complement ``s = c - b^T A^-1 b``. Also returns ``A^-1 b`` and ``s``, from which
    ``_marginals`` makes the covariances."""
    factors = scipy.sparse.linalg.splu(poses)
    solved, through = factors.solve(np.column_stack([right[:-1], coupling])).T
    schur = corner - coupling @ through
    last = (right[-1] - coupling @ solved) / schur
    return np.r_[solved - through * last, last], through, schur


def solve_graph(
    graph: PoseGraph,
    initial: np.ndarray,
    params: SolveParams | None = None,
    covariances: bool = True,
    drift: float = 0.0,
) -> GraphSolution:
    """The robust optimum of ``graph`` from ``initial`` poses (S, 3) and heading ``drift`` (rad/m),
    pose 0 held (module docstring)."""
    params = params or SolveParams()
    sigma = params.drift_sigma
    state = _State(np.array(initial, dtype=float), drift if sigma > 0 else 0.0)
    phi = params.kernel_chi2
    if graph.nodes < 2:  # one pose, held: nothing to solve, the drift its prior
        zeros = np.zeros((graph.nodes, 3, 3)) if covariances else None
        return GraphSolution(
            state.poses, zeros, np.ones(len(graph), bool), np.zeros(len(graph)), 0.0, 0, 0, True, state.drift, sigma
        )
    # 1. Graduated non-convexity on the robust edges: start where every edge is quadratic.
    robust = graph.robust
    state, solves, _ = _levenberg_marquardt(graph, state, np.inf, params.max_iterations, params.step_tolerance, sigma)
    if robust.any():
        mu = max(1.0, float(edge_chi2(graph, state.poses, state.drift)[robust].max()) / phi)
        while True:
            last = mu <= 1.0
            count = params.max_iterations if last else params.gnc_iterations
            state, made, _ = _levenberg_marquardt(graph, state, mu * phi, count, params.step_tolerance, sigma)
            solves += made
            if last:
                break
            mu = max(1.0, mu / params.gnc_factor)
    # 2. Keep the robust edges that fit; solve the kept graph as a Gaussian problem.
    kept = ~robust | (edge_chi2(graph, state.poses, state.drift) <= phi)
    final = graph.select(kept)
    state, made, converged = _levenberg_marquardt(
        final, state, np.inf, params.max_iterations, params.step_tolerance, sigma
    )
    solves += made
    chi2 = edge_chi2(graph, state.poses, state.drift)
    pose_covariances, drift_sigma = None, 0.0
    if covariances:
        pose_covariances = np.zeros((graph.nodes, 3, 3))
        pose_covariances[1:], drift_sigma = _marginals(final, state, sigma)
    return GraphSolution(
        poses=state.poses,
        covariances=pose_covariances,
        kept=kept,
        edge_chi2=chi2,
        chi2=float(chi2[kept].sum()),
        dof=3 * len(final) - 3 * (graph.nodes - 1),
        iterations=solves,
        converged=converged,
        drift=state.drift,
        drift_sigma=drift_sigma,
    )


def _marginals(graph: PoseGraph, state: _State, drift_sigma: float) -> tuple[np.ndarray, float]:
    """The poses' marginal covariances (S-1, 3, 3) relative to pose 0 at ``state`` (the Gaussian
    graph of the kept edges), and the drift's standard deviation (0 when ``drift_sigma`` is 0).

    With the drift, the information is bordered (``_bordered``): the poses' covariance is ``A^-1 +
    (A^-1 b)(A^-1 b)^T / s`` and the drift's variance ``1 / s``."""
    estimated = drift_sigma > 0
    _, jacobian = whitened_system(graph, state.poses, np.ones(len(graph)), 0, state.drift if estimated else None)
    information = (jacobian.T @ jacobian).tocsc()
    if not estimated:
        return marginal_covariances(information), 0.0
    poses, coupling, corner = _blocks(information, drift_sigma**-2)
    _, through, schur = _bordered(poses, coupling, corner, np.zeros(len(coupling) + 1))
    by_drift = through.reshape(-1, 3)
    covariances = marginal_covariances(poses) + by_drift[:, :, None] * by_drift[:, None, :] / schur
    return covariances, math.sqrt(1.0 / schur)


def robust_cost(graph: PoseGraph, poses: np.ndarray, params: SolveParams | None = None, drift: float = 0.0) -> float:
    """The cost ``solve_graph`` minimises, at ``poses`` (S, 3) and heading ``drift`` (rad/m), with the
    kernel at its final width: ``sum_k rho_k(chi2_k)`` (module docstring), plus the drift's prior
    term. Two solutions of one graph compare by it."""
    params = params or SolveParams()
    chi2 = edge_chi2(graph, poses, drift)
    return _cost(chi2, graph.robust, params.kernel_chi2) + _drift_prior_cost(drift, params.drift_sigma)


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
