"""The pose graph's algebra and its robust solve on hand-made graphs: residual Jacobians against
finite differences, a chain without loops (the solve returns the chain and the chain's propagated
covariance), a corridor ring closed by a true closure, and a planted false closure the robust
kernel drops."""

import numpy as np
import pytest

from mazeslam.core.geometry import chained, compose, relative, wrap_angle
from mazeslam.posegraph.graph import EdgeKind, PoseGraph, edge_residuals, whitened_system
from mazeslam.posegraph.params import SolveParams
from mazeslam.posegraph.solve import robust_cost, solve_graph


def _numeric_jacobian(function, x, step=1e-6):
    base = function(x)
    columns = []
    for k in range(len(x)):
        moved = x.copy()
        moved[k] += step
        difference = function(moved) - base
        difference[2::3] = wrap_angle(difference[2::3])
        columns.append(difference / step)
    return np.column_stack(columns)


def test_residual_jacobians_match_finite_differences():
    rng = np.random.default_rng(1)
    poses = np.column_stack([rng.uniform(-3, 3, (4, 2)), rng.uniform(-3, 3, 4)])
    graph = PoseGraph.of_edges(
        4, [0, 1, 3, 0], [1, 2, 1, 3], rng.normal(size=(4, 3)), np.tile(np.eye(3), (4, 1, 1)), EdgeKind.SEQUENTIAL
    )
    residual, j_from, j_to = edge_residuals(graph, poses)
    for edge in range(len(graph)):
        i, j = graph.i[edge], graph.j[edge]
        for pose, analytic in ((i, j_from[edge]), (j, j_to[edge])):

            def moved(x, pose=pose, edge=edge):
                changed = poses.copy()
                changed[pose] = x
                return edge_residuals(graph, changed)[0][edge]

            np.testing.assert_allclose(_numeric_jacobian(moved, poses[pose].copy()), analytic, atol=1e-5)
    # The whitened system's columns are the same Jacobians, pose 0 left out, scaled by W sqrt(weight).
    weights = np.array([1.0, 0.25, 4.0, 1.0])
    information = np.array([[[4.0, 1.0, 0.0], [1.0, 2.0, 0.5], [0.0, 0.5, 3.0]]] * 4)
    graph = PoseGraph(4, graph.i, graph.j, graph.measured, information, graph.kind)
    whitened, jacobian = whitened_system(graph, poses, weights, fixed=0)

    def stacked(x):
        changed = poses.copy()
        changed[1:] = x.reshape(3, 3)
        return whitened_system(graph, changed, weights, fixed=0)[0]

    np.testing.assert_allclose(_numeric_jacobian(stacked, poses[1:].ravel()), jacobian.toarray(), atol=1e-5)
    chi2 = np.einsum("ei,eij,ej->e", residual, information, residual)
    assert whitened @ whitened == pytest.approx(np.sum(weights * chi2))
    # With the heading drift as one more unknown: its column is d(W r)/d drift, the drift times each
    # edge's signed travel added to its heading residual.
    drift = 0.003
    whitened, jacobian = whitened_system(graph, poses, weights, fixed=0, drift=drift)

    def with_drift(x):
        changed = poses.copy()
        changed[1:] = x[:-1].reshape(3, 3)
        return whitened_system(graph, changed, weights, fixed=0, drift=x[-1])[0]

    unknowns = np.r_[poses[1:].ravel(), drift]
    assert jacobian.shape == (12, 10)
    np.testing.assert_allclose(_numeric_jacobian(with_drift, unknowns), jacobian.toarray(), atol=1e-5)
    travel = np.hypot(*graph.measured[:, :2].T) * np.sign(graph.j - graph.i)
    shifted = edge_residuals(graph, poses, drift)[0] - residual
    np.testing.assert_allclose(shifted[:, 2], wrap_angle(drift * travel), atol=1e-12)


def _propagated_chain_covariance(poses, increments, covariances, drift_sigma=0.0):
    """Sigma_{k+1} = A Sigma_k A^T + B Q_k B^T for x_{k+1} = x_k (+) u_k, first pose known; the
    state augmented by the heading drift (prior standard deviation ``drift_sigma`` rad/m), which
    turns increment k by -drift times its length."""
    out = np.zeros((len(poses), 4, 4))
    out[0, 3, 3] = drift_sigma**2
    for k, (u, q) in enumerate(zip(increments, covariances)):
        c, s = np.cos(poses[k, 2]), np.sin(poses[k, 2])
        a = np.eye(4)
        a[0, 2], a[1, 2], a[2, 3] = -s * u[0] - c * u[1], c * u[0] - s * u[1], -np.hypot(u[0], u[1])
        b = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1], [0, 0, 0]])
        out[k + 1] = a @ out[k] @ a.T + b @ q @ b.T
    return out[:, :3, :3]


@pytest.mark.parametrize("drift_sigma", [0.0, 0.002])
def test_a_graph_without_loops_is_the_odometry_chain_and_its_covariance_grows_as_the_chains(drift_sigma):
    rng = np.random.default_rng(2)
    increments = np.column_stack([rng.uniform(0.2, 0.5, 30), rng.normal(0, 0.05, 30), rng.normal(0, 0.2, 30)])
    covariances = np.array([np.diag([0.02**2, 0.01**2, 0.01**2]) + 1e-5 * np.ones((3, 3)) for _ in increments])
    chain = chained([1.0, 2.0, 0.3], increments)
    graph = PoseGraph.of_edges(31, np.arange(30), np.arange(1, 31), increments, covariances, EdgeKind.SEQUENTIAL)
    start = chain + rng.normal(0, 0.05, chain.shape)
    start[0] = chain[0]
    solution = solve_graph(graph, start, SolveParams(drift_sigma=drift_sigma))
    np.testing.assert_allclose(solution.poses, chain, atol=1e-6)
    assert solution.chi2 == pytest.approx(0.0, abs=1e-8)
    assert solution.drift == pytest.approx(0.0, abs=1e-9)  # no loop: the prior's mean
    assert solution.drift_sigma == pytest.approx(drift_sigma, rel=1e-6)  # and its spread
    expected = _propagated_chain_covariance(chain, increments, covariances, drift_sigma)
    np.testing.assert_allclose(solution.covariances, expected, rtol=1e-6, atol=1e-12)
    assert np.all(np.diff(np.trace(solution.covariances, axis1=1, axis2=2)) > 0)


def _corridor_ring(rng, laps=1.0):
    """True poses round a 12 x 8 m corridor ring every 0.4 m, and odometry increments with noise
    and a heading bias (dead reckoning drifts by metres over the lap)."""
    truth = [np.array([0.0, 0.0, 0.0])]
    for side in [12.0, 8.0, 12.0, 8.0] * int(np.ceil(laps)):
        steps = int(side / 0.4)
        for _ in range(steps):
            truth.append(compose(truth[-1], [0.4, 0.0, 0.0]))
        truth[-1] = compose(truth[-1], [0.0, 0.0, np.pi / 2])
    truth = np.array(truth)
    increments = relative(truth[:-1], truth[1:])
    sigma = np.array([0.01, 0.01, 0.004])
    noisy = increments + rng.normal(0, 1, increments.shape) * sigma + np.array([0, 0, 0.006])
    covariances = np.tile(np.diag(sigma**2 + np.array([0, 0, 0.006**2])), (len(noisy), 1, 1))
    return truth, noisy, covariances


def _ring_graph(truth, noisy, covariances, closures):
    """Sequential edges of ``noisy`` plus closure edges (anchor, query, measured) with 3 cm, 0.01 rad."""
    count = len(truth)
    graph = PoseGraph.of_edges(
        count, np.arange(count - 1), np.arange(1, count), noisy, covariances, EdgeKind.SEQUENTIAL
    )
    for anchor, query, measured in closures:
        graph = graph + PoseGraph.of_edges(
            count, [anchor], [query], [measured], [np.diag([0.03**2, 0.03**2, 0.01**2])], EdgeKind.CLOSURE
        )
    return graph


def _position_error(poses, truth):
    return np.hypot(*(poses[:, :2] - truth[:, :2]).T)


def test_a_true_closure_pulls_the_end_of_a_ring_back_to_its_start():
    rng = np.random.default_rng(3)
    truth, noisy, covariances = _corridor_ring(rng)
    chain = chained(truth[0], noisy)
    assert _position_error(chain, truth)[-1] > 1.0  # dead reckoning is metres off at the end
    closures = [(0, len(truth) - 1, relative(truth[0], truth[-1])), (2, len(truth) - 2, relative(truth[2], truth[-2]))]
    solution = solve_graph(_ring_graph(truth, noisy, covariances, closures), chain)
    assert solution.kept.all()
    assert _position_error(solution.poses, truth)[-1] < 0.1
    assert _position_error(solution.poses, truth).max() < 0.3
    assert solution.converged


def test_the_robust_solve_rejects_a_planted_false_closure_and_the_map_does_not_fold():
    rng = np.random.default_rng(4)
    truth, noisy, covariances = _corridor_ring(rng)
    chain = chained(truth[0], noisy)
    last = len(truth) - 1
    true = [(k, last - k, relative(truth[k], truth[last - k])) for k in range(0, 3)]
    # The false one: a scan half way round said to be where the scan a quarter round is (a
    # corridor that looks like another), 6 m or more from where it is.
    false = [(25, 52, np.array([0.4, 0.0, 0.0]))]
    assert np.hypot(*relative(truth[25], truth[52])[:2]) > 6.0
    graph = _ring_graph(truth, noisy, covariances, true + false)
    solution = solve_graph(graph, chain)
    closure = graph.kind == EdgeKind.CLOSURE
    assert list(solution.kept[closure]) == [True, True, True, False]
    clean = solve_graph(_ring_graph(truth, noisy, covariances, true), chain)
    np.testing.assert_allclose(solution.poses, clean.poses, atol=1e-6)
    assert _position_error(solution.poses, truth).max() < 0.3
    # Without the kernel the false closure folds the ring: metres of error.
    from mazeslam.posegraph.solve import _levenberg_marquardt, _State

    folded, _, _ = _levenberg_marquardt(graph, _State(chain, 0.0), np.inf, 50, 1e-6, 0.0)
    assert _position_error(folded.poses, truth).max() > 1.0


def test_the_matches_heading_drift_is_found_by_the_loop_and_taken_out_of_the_path():
    # Sequential edges round the ring whose measured turn is short by 1.5 mrad per metre (0.6 mrad
    # a 0.4 m step, 0.1 rad over the lap) on top of their noise, closed by true closures of a few
    # metres (which carry the drift of their own few metres): the drift is the one the loop shows.
    rng = np.random.default_rng(6)
    truth, _, _ = _corridor_ring(rng)
    increments = relative(truth[:-1], truth[1:])
    sigma = np.array([0.01, 0.01, 0.001])
    drift = -0.0015
    noisy = increments + rng.normal(0, 1, increments.shape) * sigma
    noisy[:, 2] += drift * np.hypot(noisy[:, 0], noisy[:, 1])
    covariances = np.tile(np.diag(sigma**2), (len(noisy), 1, 1))
    last = len(truth) - 1
    closures = []
    for k in range(3):
        measured = relative(truth[k], truth[last - k])
        measured[2] += drift * np.hypot(*measured[:2]) * np.sign(last - 2 * k)
        closures.append((k, last - k, measured))
    graph = _ring_graph(truth, noisy, covariances, closures)
    chain = chained(truth[0], noisy)
    with_drift = solve_graph(graph, chain, SolveParams(drift_sigma=0.002))
    without = solve_graph(graph, chain, SolveParams(drift_sigma=0.0))
    assert without.drift == 0.0 and without.drift_sigma == 0.0
    assert 0 < with_drift.drift_sigma < 0.25 * 0.002  # the loop decides it, not the prior
    assert abs(with_drift.drift - drift) < 3 * with_drift.drift_sigma
    error, error_without = _position_error(with_drift.poses, truth), _position_error(without.poses, truth)
    assert np.sqrt(np.mean(error**2)) < 0.7 * np.sqrt(np.mean(error_without**2))  # 0.05 m against 0.09 m
    assert with_drift.chi2 < without.chi2


def test_the_solve_is_deterministic():
    rng = np.random.default_rng(5)
    truth, noisy, covariances = _corridor_ring(rng)
    chain = chained(truth[0], noisy)
    graph = _ring_graph(truth, noisy, covariances, [(0, len(truth) - 1, relative(truth[0], truth[-1]))])
    first, second = solve_graph(graph, chain), solve_graph(graph, chain)
    assert np.array_equal(first.poses, second.poses)
    assert np.array_equal(first.covariances, second.covariances)


def test_a_single_pose_is_returned_as_given_with_the_drift_its_prior():
    solution = solve_graph(PoseGraph.empty(1), np.array([[1.0, 2.0, 0.5]]), SolveParams(drift_sigma=0.004))
    np.testing.assert_array_equal(solution.poses, [[1.0, 2.0, 0.5]])
    assert solution.covariances.shape == (1, 3, 3) and solution.converged
    assert (solution.drift, solution.drift_sigma) == (0.0, 0.004)  # no edge decides it


def test_the_robust_cost_is_chi2_on_plain_edges_and_geman_mcclure_on_robust_ones():
    # Two poses 1 m apart along x; a sequential edge measuring 1.1 m (sigma 0.1 m: chi2 1) and a
    # closure measuring 2 m (sigma 0.1 m: chi2 100), cost 1 + Phi 100 / (Phi + 100).
    poses = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    covariance = np.diag([0.01, 0.01, 0.01])
    graph = PoseGraph.of_edges(2, [0], [1], [[1.1, 0.0, 0.0]], [covariance], EdgeKind.SEQUENTIAL) + PoseGraph.of_edges(
        2, [0], [1], [[2.0, 0.0, 0.0]], [covariance], EdgeKind.CLOSURE
    )
    phi = 11.34
    assert robust_cost(graph, poses) == pytest.approx(1.0 + phi * 100.0 / (phi + 100.0))
    # The solve lowers it: the closure's pull is bounded, the sequential edge wins.
    solution = solve_graph(graph, poses)
    assert robust_cost(graph, solution.poses) < robust_cost(graph, poses)
    assert solution.poses[1, 0] == pytest.approx(1.1, abs=1e-3)
    assert list(solution.kept) == [True, False]
