"""``mazeslam slam`` with ``[map] kind = "grid"``: the grid filter over a log, its outputs, how it did.

Outputs in the run's folder: ``occupancy.pgm`` + ``occupancy.yaml`` (ROS map_server) and
``occupancy.png`` (the best particle's map), ``slam.png`` (that map with the paths and particles),
``trajectory.csv`` (the cloud's weighted mean at every
record with its covariance), ``best_trajectory.csv`` (the best particle's path), ``map.json``
(run facts and, with truth, the errors; strict JSON) and, with ``--animate``, ``slam.mp4`` or
``slam.gif`` (the best particle's map growing, ``mazeslam.grid.animation``).
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

from mazeslam import sidecars
from mazeslam.config import jsonable
from mazeslam.evaluation.consistency import POSE_BOUND_95, nees_summary, summarise
from mazeslam.evaluation.metrics import normalized_estimation_error
from mazeslam.evaluation.scoring import DEAD_RECKONING, error_table
from mazeslam.evaluation.sharpness import dead_reckoning_without_glitches, paths_sharpness, sharpness_lines
from mazeslam.grid.figure import plot_grid_run
from mazeslam.grid.filter import GridSlamParams, GridSlamResult, run_grid_slam
from mazeslam.grid.map_io import grid_states, write_map
from mazeslam.loaded_run import LoadedRun
from mazeslam.slam import SlamConfig

#: About how many frames ``--animate`` draws, whatever the log's length.
ANIMATION_FRAMES = 150

#: The grid filter's rows in the error table.
GRID_MEAN, GRID_BEST = "grid filter (mean)", "grid filter (best particle)"


def grid_params(config: SlamConfig) -> GridSlamParams:
    """``[grid]``, moving by ``[scan_matching]``'s laser odometry when that is enabled."""
    if config.scan_matching.enabled:
        return dataclasses.replace(config.grid, laser_odometry=config.scan_matching)
    return config.grid


def grid_on_run(run: LoadedRun, config: SlamConfig, progress: bool = False, snapshot_every: int = 0) -> GridSlamResult:
    """The grid filter over ``run``, moving by its odometry with the glitch pairs summed and lone
    glitches left out (``[odometry] jump_tolerance``), the sensor's maximum range from the map
    sidecar (``[grid.grid] clear_no_return``); ``snapshot_every``: see ``run_grid_slam``."""
    moved_by = run.log_with_glitch_pairs_summed(config.odometry.jump_tolerance)
    params = grid_params(config)
    return run_grid_slam(moved_by, run.geometry, run.start_pose, params, progress, snapshot_every, run.sensor_max_range)


def run_grid_command(
    run: LoadedRun, config: SlamConfig, out_dir: Path, progress: bool = True, animate: bool = False
) -> list[str]:
    """Run the grid filter on ``run`` (laser odometry from ``[scan_matching]`` when enabled), write
    its outputs into ``out_dir`` and return the lines to print. ``animate``: also the map growing,
    ``slam.mp4`` (with ffmpeg) or ``slam.gif``, about ``ANIMATION_FRAMES`` frames."""
    params = grid_params(config)
    scans = int(run.log.is_scan.sum())
    result = grid_on_run(run, config, progress, max(1, scans // ANIMATION_FRAMES) if animate else 0)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = {
        "occupancy": write_map(grid_states(result.grid), out_dir),
        "trajectory": out_dir / "trajectory.csv",
        "best_trajectory": out_dir / "best_trajectory.csv",
        "map": out_dir / "map.json",
    }
    mean, covariances = result.record_trajectory(which="mean")
    sidecars.write_trajectory(paths["trajectory"], run.log.times, mean, covariances)
    best = result.record_trajectory()[0]
    sidecars.write_truth(paths["best_trajectory"], run.log.times, best)
    paths["figure"] = plot_grid_run(
        out_dir / "slam.png",
        grid_states(result.grid),
        mean,
        best,
        result.particles.poses,
        f"{run.path.name}: grid filter, {params.particles} particles",
        run.truth,
        "reference path" if run.truth_is_reference else "true path",
    )
    if animate:
        from mazeslam.grid.animation import animate_grid

        truth = run.truth[result.scan_records] if run.truth is not None else None
        paths["animation"] = animate_grid(
            out_dir / "slam.gif",
            result.snapshots,
            result.mean_poses,
            f"{run.path.name}: grid filter, {params.particles} particles",
            truth,
            "reference path" if run.truth_is_reference else "true path",
            progress=progress,
        )
    duration, seconds = run.log.duration, result.total_seconds
    lines = [
        f"{run.path}: {len(run.log)} records, {len(result.scan_records)} scans "
        f"({int(result.processed.sum())} processed); beam geometry from {run.geometry_origin}",
        f"grid filter: {params.particles} particles, {result.resamplings} resamplings, {seconds:.1f} s"
        + (f" ({duration / max(seconds, 1e-9):.1f}x real time)" if duration > 0 else "")
        + f", peak map memory {result.peak_map_bytes / 2**20:.0f} MB (tiles shared between particles)",
    ]
    glitches = run.glitch_line(config.odometry.jump_tolerance, pairs_summed=True)
    if glitches:
        lines.append(glitches)
    document = {
        "kind": "grid",
        "source": str(run.path),
        "beam_geometry": run.geometry.to_dict(),
        "start_pose": run.start_pose,
        "parameters": dataclasses.asdict(params),
        "scans": len(result.scan_records),
        "processed_scans": int(result.processed.sum()),
        "resamplings": result.resamplings,
        "seconds_total": seconds,
        "peak_map_bytes": result.peak_map_bytes,
        "occupancy": paths["occupancy"].name,
    }
    nis = summarise(result.nis, POSE_BOUND_95)
    lines.append(_motion_nis_line(nis))
    document["motion_nis"] = nis
    span = params.grid.min_range, params.grid.max_range
    sharpness = paths_sharpness(run, {"mean path": mean, "best particle": best}, config.odometry.jump_tolerance, *span)
    lines += sharpness_lines(sharpness, *span)
    document["sharpness"] = {name: value.to_dict() for name, value in sharpness.items()}
    if run.truth is not None:
        table, nees = _errors(run, result, config.odometry.jump_tolerance)
        lines += [
            f"Errors against {run.truth_label}, at the scans: ATE [m] (aligned: after the best rigid motion); "
            + (
                f"pose NEES median {nees['median']:.2f}, {100 * nees['inside_95']:.0f} % inside "
                f"{POSE_BOUND_95:.2f} (consistent: 3)"
                if nees["count"]
                else "no pose NEES (the particles' covariance is singular at every scan: too few particles)"
            ),
            table.to_markdown(floatfmt=".4f"),
        ]
        document["ate"], document["nees"] = table.reset_index().to_dict(orient="records"), nees
    else:
        lines.append("no ground truth beside the log: no errors to report")
    paths["map"].write_text(json.dumps(jsonable(document), indent=1, allow_nan=False) + "\n")
    return lines + ["wrote " + ", ".join(str(p) for p in paths.values())]


def _motion_nis_line(nis: dict) -> str:
    """The motion NIS (``mazeslam.grid.filter.motion_nis``, summarised) in words."""
    if not nis["count"]:
        return "Uncertainty: no motion NIS (no scan was matched)"
    return (
        f"Uncertainty: motion NIS of {nis['count']} matched scans mean {nis['mean']:.2f}, median "
        f"{nis['median']:.2f}, {100 * nis['inside_95']:.0f} % inside {POSE_BOUND_95:.2f} (consistent: 3; "
        "far less: [grid] motion_noise is wider than the corrections the scan matches make, far more: narrower)"
    )


def _errors(run: LoadedRun, result: GridSlamResult, jump_tolerance: float):
    """The error table at the scans (dead reckoning with the glitches left out, the filter's mean and
    best paths against the truth) and the mean path's NEES summary."""
    assert run.truth is not None
    records = result.scan_records
    truth = run.truth[records]
    table = error_table(
        {
            DEAD_RECKONING: dead_reckoning_without_glitches(run, jump_tolerance)[records],
            GRID_MEAN: result.mean_poses,
            GRID_BEST: result.best_poses,
        },
        truth,
    )
    nees = normalized_estimation_error(result.mean_poses, result.covariances, truth)
    return table, nees_summary(nees)
