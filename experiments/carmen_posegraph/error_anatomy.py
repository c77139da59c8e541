"""Where each CARMEN log's pose-graph error lies. The graph is rebuilt as run.py builds it, and then:

* the scans its aligned path puts more than ``FAR`` m from the log's reference poses, as stretches of
  consecutive scans (first-last scan, the largest error), and the aligned ATE without them;
* the same graph solved again from its solution without its local edges, and without its closures
  (the robust solve as ``laser_pose_graph`` runs it), and the ATE of each;
* the local and closure matches accepted whose pose is more than ``WRONG`` m from the relative pose
  of the reference, and of those how many were matched from guesses (the estimate's relative pose,
  and on a log without odometry the alternatives an ambiguous step gives) all already that far off,
  within a window (the sequential chain's covariance) narrower than the error: the estimate's
  mistake confirmed rather than found;
* of the graph's local and closure edges that far off, how many the robust solve kept; the graph
  solved again without them (the reference deciding which: an upper bound on what a better
  rejection could give) and its ATE; and that solution's robust cost (every edge counted,
  ``mazeslam.posegraph.solve.robust_cost``) over the graph's own: near 1, the graph's objective
  cannot tell the two apart.

The matches are recorded by wrapping ``mazeslam.posegraph.laser_graph``'s ``candidate_pairs`` and
``match_to_submap`` in the worker process; the library is unchanged.

Run: ``python -m experiments.carmen_posegraph.error_anatomy [--logs aces ...] [--jobs 2]``; writes
results/error_anatomy.csv and results/error_anatomy.md. About 7 CPU minutes (every graph rebuilt).
"""

from __future__ import annotations

import argparse
from unittest import mock

import numpy as np
import pandas as pd

from experiments.carmen_grid.run import LOGS, imported_run, run_jobs, slam_config
from experiments.carmen_posegraph.run import RESULTS
from mazeslam.core.geometry import relative
from mazeslam.evaluation.metrics import absolute_trajectory_error, align_se2, apply_se2
from mazeslam.posegraph import laser_graph
from mazeslam.posegraph.graph import EdgeKind, PoseGraph, edge_residuals
from mazeslam.posegraph.params import PoseGraphParams, SolveParams
from mazeslam.posegraph.solve import GraphSolution, robust_cost, solve_graph

#: A scan this far (m) from the reference after alignment is in an error stretch.
FAR = 0.3
#: An accepted match this far (m) from the reference's relative pose is wrong.
WRONG = 0.5


def stretches(errors: np.ndarray) -> list[tuple[int, int, float]]:
    """Runs of consecutive scans with ``errors`` (S,) above ``FAR``: (first, last, largest error)."""
    runs, start = [], None
    for index, far in enumerate(np.append(errors > FAR, False)):
        if far and start is None:
            start = index
        elif not far and start is not None:
            runs.append((start, index - 1, float(errors[start:index].max())))
            start = None
    return runs


def _described(stretch: tuple[int, int, float]) -> str:
    first, last, largest = stretch
    return f"{first}-{last} ({largest:.2f} m)" if first != last else f"{first} ({largest:.2f} m)"


class MatchLog:
    """The local and closure matches ``laser_pose_graph`` tries: (anchor, query, guesses (G, 3),
    window standard deviation in position (m), the match)."""

    def __init__(self):
        self.entries: list[tuple] = []
        self.pair: tuple[int, int] | None = None

    def pairs(self, original):
        def recorded(*args, **kwargs):
            for anchor, query, kind in original(*args, **kwargs):
                self.pair = (anchor, query)
                yield anchor, query, kind
            self.pair = None

        return recorded

    def matches(self, original):
        def recorded(submap, points, guess, window, *args, **kwargs):
            match = original(submap, points, guess, window, *args, **kwargs)
            if self.pair is not None:  # not the blind intervals' ambiguity test
                self.entries.append((*self.pair, np.atleast_2d(guess), float(np.sqrt(window[0, 0])), match))
            return match

        return recorded


def confirmed_matches(entries: list[tuple], reference: np.ndarray) -> int:
    """The accepted matches more than ``WRONG`` m off the reference that were matched from guesses
    all as far off, within a window narrower than the nearest guess's error."""
    confirmed = 0
    for anchor, query, guesses, window_sigma, match in entries:
        truth = relative(reference[anchor], reference[query])
        guess_error = float(np.hypot(*(guesses[:, :2] - truth[:2]).T).min())
        wrong = np.hypot(*(match.pose[:2] - truth[:2])) > WRONG
        confirmed += match.accepted and wrong and guess_error > WRONG and window_sigma < guess_error
    return int(confirmed)


def wrong_match_edges(graph: PoseGraph, reference: np.ndarray) -> np.ndarray:
    """(E,) bool: the local and closure edges (the accepted matches) whose measurement is more than
    ``WRONG`` m from the relative pose of the reference poses (S, 3)."""
    residual = edge_residuals(graph, reference)[0]
    return matched_edges(graph) & (np.hypot(residual[:, 0], residual[:, 1]) > WRONG)


def matched_edges(graph: PoseGraph) -> np.ndarray:
    """(E,) bool: the local and closure edges, one per accepted match."""
    return np.isin(graph.kind, [int(EdgeKind.LOCAL), int(EdgeKind.CLOSURE)])


def cost_ratio(graph: PoseGraph, other: GraphSolution, solved: GraphSolution, params: SolveParams) -> float:
    """The robust cost of ``graph`` (every edge) at ``other``'s poses and drift over that at ``solved``'s."""
    return robust_cost(graph, other.poses, params, other.drift) / robust_cost(graph, solved.poses, params, solved.drift)


def anatomy_row(name: str) -> dict:
    """One log's graph, rebuilt and dissected (module docstring)."""
    run = imported_run(name)
    log = MatchLog()
    with (
        mock.patch.object(laser_graph, "candidate_pairs", log.pairs(laser_graph.candidate_pairs)),
        mock.patch.object(laser_graph, "match_to_submap", log.matches(laser_graph.match_to_submap)),
    ):
        result = laser_graph.laser_pose_graph(run, slam_config(run))
    reference = run.truth[result.scan_records]
    moved = apply_se2(align_se2(result.poses, reference), result.poses)
    errors = np.hypot(*(moved[:, :2] - reference[:, :2]).T)
    near = errors <= FAR
    graph, solve, drift = result.graph, PoseGraphParams().solve, result.solution.drift
    without = {}
    for label, kind in (("local", EdgeKind.LOCAL), ("closures", EdgeKind.CLOSURE)):
        solved = solve_graph(graph.select(graph.kind != kind), result.poses, solve, covariances=False, drift=drift)
        without[label] = absolute_trajectory_error(solved.poses, reference, align=True)["rmse"]
    wrong_edges = wrong_match_edges(graph, reference)
    without_wrong = solve_graph(graph.select(~wrong_edges), result.poses, solve, covariances=False, drift=drift)
    return {
        "log": name,
        "scans": len(errors),
        "ate_m": float(np.sqrt(np.mean(errors**2))),
        "scans_far": int((~near).sum()),
        "ate_without_far_m": float(np.sqrt(np.mean(errors[near] ** 2))),
        "stretches": "; ".join(_described(stretch) for stretch in stretches(errors)),
        "ate_without_local_m": without["local"],
        "ate_without_closures_m": without["closures"],
        "matches_accepted": int(matched_edges(graph).sum()),
        "matches_wrong": int(wrong_edges.sum()),
        "wrong_from_wrong_guess": confirmed_matches(log.entries, reference),
        "wrong_kept": int((wrong_edges & result.solution.kept).sum()),
        "ate_without_wrong_m": absolute_trajectory_error(without_wrong.poses, reference, align=True)["rmse"],
        "cost_without_wrong_over_graph": cost_ratio(graph, without_wrong, result.solution, solve),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--logs", nargs="+", default=LOGS)
    parser.add_argument("--jobs", type=int, default=1)
    args = parser.parse_args()
    path = RESULTS / "error_anatomy.csv"
    run_jobs(anatomy_row, [(name,) for name in args.logs], args.jobs, path, ["log"])
    table = pd.read_csv(path, keep_default_na=False)
    header = (
        f"Where the pose graph's error lies on each CARMEN log (experiments/carmen_posegraph/error_anatomy.py): the "
        f"aligned ATE against the reference poses; the scans more than {FAR} m off, their stretches (scans, the "
        "largest error) and the ATE without them; the graph solved again without its local edges and without its "
        f"closures; the local and closure matches accepted, those more than {WRONG} m from the reference's relative "
        "pose, and of those the ones matched from a guess already that far off within a narrower window; the "
        "graph's edges that far off kept by the robust solve, the graph solved again without them (the reference "
        "choosing them) and that solution's robust cost over the graph's own.\n\n"
    )
    (RESULTS / "error_anatomy.md").write_text(header + table.to_markdown(index=False, floatfmt=".3g") + "\n")


if __name__ == "__main__":
    main()
