"""``mazeslam smooth`` with a grid config: a laser log's pose graph (``mazeslam.smoothing.laser_optimum``),
the lines it prints and the files it writes (``mazeslam.cli.smooth`` dispatches here on ``[map] kind``)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from mazeslam.cli.run_folders import SMOOTH_FILES
from mazeslam.core.motion import dead_reckoning
from mazeslam.core.outputs import staged_outputs, write_json
from mazeslam.data import sidecars
from mazeslam.data.loaded_run import LoadedRun
from mazeslam.data.map_io import write_map
from mazeslam.evaluation.consistency import POSE_BOUND_95, nees_summary, summary_words
from mazeslam.evaluation.metrics import normalized_estimation_error
from mazeslam.evaluation.scoring import DEAD_RECKONING, error_table
from mazeslam.pipeline import SlamConfig
from mazeslam.posegraph.graph import EdgeKind
from mazeslam.smoothing.laser_optimum import LaserSmoothed, smooth_laser_run
from mazeslam.smoothing.optimum import OPTIMUM

#: The laser odometry chained, in error tables: what the graph starts from.
LASER_ODOMETRY = "laser odometry"


def laser_smooth_lines(run: LoadedRun, config: SlamConfig, out_dir: Path) -> list[str]:
    """Build and solve the pose graph of the loaded log ``run`` with ``config``, write
    ``out_dir``/{trajectory.csv, trajectory.tum, map.json, occupancy.pgm/.yaml, smooth.png} (replacing
    the last run's files once all are written: ``staged_outputs``); return the lines to print."""
    smoothed = smooth_laser_run(run, config)
    result, solution = smoothed.graph, smoothed.graph.solution
    kinds = result.graph.kind
    duration = run.log.duration
    speed = f" ({duration / max(smoothed.seconds, 1e-9):.0f}x real time)" if duration > 0 else ""
    lines = [
        (
            f"{run.path}: pose graph of {len(result.poses)} scans, {len(kinds)} edges ({_edge_counts(kinds)}); "
            f"beam geometry: {run.geometry_origin}"
        ),
        (
            f"Matches tried: {result.tried['local']} local, {result.tried['closure']} closures; accepted as "
            f"unambiguous: {result.accepted['local']} and {result.accepted['closure']}; refused: "
            + ", ".join(f"{count} {reason}" for reason, count in result.refused.items())
        ),
        (
            f"Robust solve: kept {result.kept(EdgeKind.CLOSURE)} loop closures, rejected "
            f"{result.rejected(EdgeKind.CLOSURE)} (and {result.rejected(EdgeKind.LOCAL)} local matches); "
            f"chi2/dof {solution.chi2_per_dof:.2f} over {solution.dof} degrees of freedom "
            f"({'converged' if solution.converged else 'NOT converged'}, {result.passes} passes); "
            f"{smoothed.seconds:.1f} s{speed}"
        ),
        drift_line(solution.drift, solution.drift_sigma, config.posegraph.solve.drift_sigma),
    ]
    document = {
        "kind": "pose graph",
        "frame": "world; metres",
        "source": str(run.path),
        "graph": _graph_facts(smoothed),
        "chi2": solution.chi2,
        "dof": solution.dof,
        "chi2_per_dof": solution.chi2_per_dof,
        "heading_drift_rad_per_m": solution.drift,
        "heading_drift_sigma_rad_per_m": solution.drift_sigma,
        "converged": solution.converged,
        "iterations": solution.iterations,
        "passes": result.passes,
        "scans": len(result.poses),
        "seconds": smoothed.seconds,
        "parameters": dataclasses.asdict(config),
    }
    if run.truth is not None:
        errors, error_lines = _errors(run, smoothed)
        document.update(errors)
        lines += error_lines
    else:
        lines.append("no ground truth beside the log: no errors to report")
    with staged_outputs(out_dir, SMOOTH_FILES) as staging:
        paths = _write_outputs(staging, run, smoothed, document)
    lines.append("wrote " + ", ".join(str(Path(out_dir) / path.name) for path in paths.values()))
    return lines


#: How the smooth command names each kind of edge; blind matches and motion priors only where a log has them.
EDGE_NAMES = {
    EdgeKind.SEQUENTIAL: "sequential",
    EdgeKind.BLIND: "blind sequential",
    EdgeKind.PRIOR: "motion priors",
    EdgeKind.LOCAL: "local",
    EdgeKind.CLOSURE: "loop closures",
}


def _edge_counts(kinds: np.ndarray) -> str:
    """The graph's edges counted by kind (``kinds`` (E,)), e.g. "439 sequential, 1432 local, 172 loop closures"."""
    always = (EdgeKind.SEQUENTIAL, EdgeKind.LOCAL, EdgeKind.CLOSURE)
    counts = {kind: int(np.sum(kinds == kind)) for kind in EDGE_NAMES}
    return ", ".join(f"{count} {EDGE_NAMES[kind]}" for kind, count in counts.items() if count or kind in always)


#: A drift whose standard deviation is above this share of its prior's was decided by the prior, not the loops.
UNDECIDED_SHARE = 0.5


def drift_line(drift: float, sigma: float, prior_sigma: float) -> str:
    """The scan matches' heading drift the solve estimated (``drift`` rad/m, standard deviation
    ``sigma``; ``prior_sigma`` the prior's, ``[posegraph.solve] drift_sigma``), as a line to print."""
    if prior_sigma == 0:
        return "Heading drift of the scan matches: not estimated (posegraph.solve.drift_sigma = 0)"
    line = f"Heading drift of the scan matches: {1000 * drift:+.3f} +/- {1000 * sigma:.3f} mrad per metre"
    if sigma > UNDECIDED_SHARE * prior_sigma:
        return line + " (no loop decides it: its prior's, 0, with the prior's spread in the covariances)"
    return line + " (taken out of the sequential, local and closure edges)"


def _graph_facts(smoothed: LaserSmoothed) -> dict:
    """The graph's size and its matches, for map.json."""
    result = smoothed.graph
    kinds = result.graph.kind
    return {
        "nodes": len(result.poses),
        "edges": {kind.name.lower(): int(np.sum(kinds == kind)) for kind in EdgeKind},
        "tried": result.tried,
        "accepted": result.accepted,
        "refused": result.refused,
        "kept_by_solve": {kind.name.lower(): result.kept(kind) for kind in (EdgeKind.LOCAL, EdgeKind.CLOSURE)},
        "rejected_by_solve": {kind.name.lower(): result.rejected(kind) for kind in (EdgeKind.LOCAL, EdgeKind.CLOSURE)},
        "closures": _closure_pairs(smoothed, kept=True).tolist(),
        "rejected_closures": _closure_pairs(smoothed, kept=False).tolist(),
    }


def _closure_pairs(smoothed: LaserSmoothed, kept: bool) -> np.ndarray:
    """The loop closures (K, 2) (node indexes) the robust solve kept, or rejected."""
    graph, solution = smoothed.graph.graph, smoothed.graph.solution
    chosen = (graph.kind == EdgeKind.CLOSURE) & (solution.kept == kept)
    return np.column_stack([graph.i[chosen], graph.j[chosen]])


def _errors(run: LoadedRun, smoothed: LaserSmoothed) -> tuple[dict, list[str]]:
    """ATE at the scans against the run's truth (or reference poses) for dead reckoning, the laser
    odometry and the graph; the graph's pose NEES there: for map.json and to print."""
    assert run.truth is not None
    scans = smoothed.graph.scan_records
    truth = run.truth[scans]
    estimates = {
        DEAD_RECKONING: dead_reckoning(run.log, run.start_pose)[scans],
        LASER_ODOMETRY: smoothed.graph.odometry_poses,
        OPTIMUM: smoothed.graph.poses,
    }
    table = error_table(estimates, truth)
    nees = nees_summary(normalized_estimation_error(smoothed.graph.poses, smoothed.graph.covariances, truth))
    lines = [
        (
            f"Errors against {run.truth_label} at the {len(scans)} scans: ATE [m] (aligned: after the best "
            "rigid motion), RPE [m, rad]:"
        ),
        table.to_markdown(floatfmt=".4f"),
        "Pose NEES at the scans (covariances relative to the first scan): " + summary_words(nees, POSE_BOUND_95, 3),
    ]
    return {"ate": table.reset_index().to_dict(orient="records"), "nees": nees}, lines


def _write_outputs(out_dir: Path, run: LoadedRun, smoothed: LaserSmoothed, document: dict) -> dict[str, Path]:
    """trajectory.csv (with covariances), trajectory.tum, occupancy.pgm/.yaml, map.json (strict JSON)
    and smooth.png (the graph over its map)."""
    from mazeslam.viz.graph_figure import plot_pose_graph

    out_dir.mkdir(parents=True, exist_ok=True)
    paths = {"trajectory": out_dir / "trajectory.csv", "tum": out_dir / "trajectory.tum", "map": out_dir / "map.json"}
    sidecars.write_trajectory(paths["trajectory"], run.log.times, smoothed.poses, smoothed.covariances)
    sidecars.write_tum(paths["tum"], run.log.times, smoothed.poses)
    paths["occupancy"] = write_map(smoothed.occupancy, out_dir)
    write_json(paths["map"], {**document, "occupancy": paths["occupancy"].name})
    result = smoothed.graph
    reference = None if run.truth is None else run.truth[result.scan_records]
    title = f"{run.path.name}: pose graph, {len(result.poses)} scans, chi2/dof {result.solution.chi2_per_dof:.2f}"
    paths["figure"] = plot_pose_graph(
        out_dir / "smooth.png",
        smoothed.occupancy,
        result.poses,
        _closure_pairs(smoothed, kept=True),
        _closure_pairs(smoothed, kept=False),
        title,
        reference,
        run.truth_path_label,
    )
    return paths
