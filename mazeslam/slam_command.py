"""``mazeslam slam``: run the filter on a log file, write its outputs, and say how it did."""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path

from mazeslam import sidecars
from mazeslam.beam_detection import convention_given, convention_warning, with_detected_convention
from mazeslam.beams import SensorOverrides
from mazeslam.config import with_changes
from mazeslam.evaluation import slam_report
from mazeslam.evaluation.consistency import EXPLANATION, OBSERVATION_BOUND_95, POSE_BOUND_95, nis_summary
from mazeslam.evaluation.scoring import RPE_DISTANCE, score_run
from mazeslam.evaluation.sharpness import paths_sharpness, sharpness_lines
from mazeslam.filters.corners import CornerExtractor
from mazeslam.loaded_run import LoadedRun, load_run
from mazeslam.side_process import SideProcess
from mazeslam.slam import MapKind, SlamConfig, SlamResult, load_slam_config, slam_on_run

#: About how many frames ``--animate`` draws, whatever the log's length.
ANIMATION_FRAMES = 150
#: What the side process loads while the filter runs: what draws ``slam.png`` and exports the map.
FIGURE_MODULES = (
    "matplotlib.figure",
    "matplotlib.backends.backend_agg",
    "matplotlib.image",
    "mazeslam.evaluation.slam_report",
    "mazeslam.evaluation.map_export",
)


def run_slam_command(
    log_file,
    config_path,
    out_dir,
    filter_changes: dict | None = None,
    sensor: SensorOverrides | None = None,
    animate=False,
    progress=True,
    live=False,
    echo=None,
    map_kind: str | None = None,
    side_process: bool = False,
) -> list[str]:
    """Run, write ``out_dir``/{trajectory.csv, best_trajectory.csv, map.json, slam.png, occupancy.pgm/.yaml/.png,
    landmarks.csv[, slam.gif]};
    return the lines to print. ``filter_changes`` replace ``[fastslam]`` settings and ``sensor``
    the ``[sensor]`` ones (None values: keep the config's). ``live``: draw the filter as it runs
    (``mazeslam.live``; its note when there is no window goes to ``echo`` at once, and to the lines).
    ``map_kind`` replaces ``[map] kind``; the particle count and seed go to the filter that runs.
    ``side_process``: corner FastSLAM's ``slam.png`` and map export are made by a ``SideProcess``
    forked before the filter runs, which loads matplotlib meanwhile and draws while this process
    scores the run and writes the rest (the command line's way; otherwise they are made here)."""
    config = load_slam_config(config_path)
    filter_changes = filter_changes or {}
    config = dataclasses.replace(
        config,
        map=with_changes(config.map, kind=map_kind),
        fastslam=with_changes(config.fastslam, **filter_changes),
        grid=with_changes(config.grid, particles=filter_changes.get("NPARTICLES"), seed=filter_changes.get("seed")),
        sensor=(sensor or SensorOverrides()).over(config.sensor),
    )
    run = load_run(log_file, config.sensor)
    run = with_detected_convention(run, config, cache_folder=Path(out_dir))
    notes = [note for note in [_given_convention_warning(run, config)] if note]
    if config.map.kind == MapKind.GRID:
        from mazeslam.grid_command import run_grid_command

        if live:
            notes.append("--live draws corner FastSLAM only; the grid filter's map is in occupancy.png")
        lines = run_grid_command(run, config, Path(out_dir), progress, animate)
        return lines[:1] + notes + lines[1:]
    with SideProcess(FIGURE_MODULES, fork=side_process) as side:
        return _corner_fastslam(log_file, run, config, out_dir, notes, animate, progress, live, echo, side)


def _corner_fastslam(
    log_file, run: LoadedRun, config: SlamConfig, out_dir, notes: list[str], animate, progress, live, echo, side
) -> list[str]:
    """``run_slam_command`` for corner FastSLAM: the filter, its outputs and lines; ``side`` (a
    ``SideProcess``) draws the figure and exports the map."""
    updates = int(run.log.is_scan.sum() + run.log.is_landmark.sum())
    every = max(1, updates // ANIMATION_FRAMES) if animate else 0  # frames for the GIF, at most ~ANIMATION_FRAMES
    view = None
    if live:
        from mazeslam.live import LiveView

        view = LiveView(run, config.corners, f"{run.path.name}: FastSLAM, {config.fastslam.NPARTICLES} particles")
        if view.message and echo is not None:
            echo(view.message)
    began = time.perf_counter()
    result = slam_on_run(run, config, progress, snapshot_every=every, on_update=view)
    if view is not None:
        view.close(len(run.log) - 1, result.filter)
    matching_seconds = time.perf_counter() - began - result.step_seconds.sum()
    lines = _run_lines(run, config, result, matching_seconds, notes)
    if view is not None:
        lines.append(
            f"Live view: {view.frames} frames drawn in {view.drawing_seconds:.1f} s"
            + ("" if view.window else " (off-screen: no display)")
        )
    span = config.corners.min_range, config.corners.max_range
    points = slam_report.scan_points_world(run.log, result.mean_poses, run.geometry, *span)
    truth_label = "reference path" if run.truth_is_reference else "true path"
    figure = slam_report.SlamFigure.of(
        result,
        points,
        truth=run.truth,
        walls=run.walls,
        true_landmarks=run.true_corners if run.world is not None else None,
        title=f"{run.path.name}: FastSLAM, {config.fastslam.NPARTICLES} particles",
        truth_label=truth_label,
    )
    side.start(slam_report.draw_and_export, out_dir, figure, run.log, run.geometry, *span)
    score = score_run(run, result, config.evaluation.match_radius)
    nis = nis_summary(result.nis)
    nis_by_kind = {kind: nis_summary(values) for kind, values in sorted(result.nis_by_kind().items())}
    line_numbers = run.log.line_numbers
    assert line_numbers is not None  # the log was read from a file: each record has its line
    extra = {
        "source": str(log_file),
        "beam_geometry": run.geometry.to_dict(),
        "start_pose": run.start_pose.tolist(),
        "parameters": dataclasses.asdict(config),
        "consistency": slam_report.consistency(result),
        "nis": nis,
        "nis_by_kind": nis_by_kind,
        "resampled_fraction": result.resampled_fraction,
        "dropped_odometry_lines": [int(line_numbers[r.index]) for r in result.dropped_odometry],
    }
    lines += _uncertainty_lines(nis, score.nees_summary if score is not None else None, nis_by_kind)
    if run.log.n_beams:
        placed_by = {"mean path": result.mean_poses, "best particle": result.best_poses}
        sharpness = paths_sharpness(run, placed_by, config.odometry.jump_tolerance, *span)
        lines += sharpness_lines(sharpness, *span)
        extra["sharpness"] = {name: value.to_dict() for name, value in sharpness.items()}
    if score is not None:
        lines += _score_lines(run, result, score, config.evaluation.match_radius)
        extra["ate"] = score.row_records()
        extra["map_error"] = score.map_errors
        extra["nees"] = score.nees_summary
        from mazeslam.smooth_command import optimum_columns, optimum_line  # the smoother: only with truth

        optimum = optimum_columns(run, config, score)
        if optimum is not None:
            lines.append(optimum_line(optimum))
            extra["optimum"] = optimum
    else:
        lines.append("no ground truth beside the log: no errors to report")
    paths = slam_report.write_outputs(out_dir, result, extra)
    if run.truth is not None:
        paths["truth_tum"] = Path(out_dir) / "truth.tum"
        sidecars.write_tum(paths["truth_tum"], run.log.times, run.truth)
    paths.update(side.result())  # slam.png and the map export
    if animate:
        from mazeslam.evaluation.slam_view import scan_source

        extractor = CornerExtractor(run.geometry, run.log.width, config.corners)
        paths["animation"] = slam_report.animate_slam(
            Path(out_dir) / "slam.gif",
            result,
            points,
            run.truth,
            run.walls,
            scan_at=scan_source(run.log, result.mean_poses, run.geometry, extractor) if run.log.n_beams else None,
            title=f"{run.path.name}: FastSLAM, {config.fastslam.NPARTICLES} particles",
            progress=progress,
            truth_label=truth_label,
        )
    lines.append("wrote " + ", ".join(str(p) for p in paths.values()))
    return lines


def _run_lines(
    run: LoadedRun, config: SlamConfig, result: SlamResult, matching_seconds: float, notes: list[str]
) -> list[str]:
    """What the run did: records, particles, resamplings, speed, laser odometry, ``notes`` (warnings), glitches."""
    course_log, seconds = run.log, result.step_seconds.sum()
    speed = (
        f" ({course_log.duration / max(seconds, 1e-9):.0f}x real time)"
        if course_log.duration > 0
        else " (the log's timestamps span no time)"
    )
    lines = [
        f"{run.path}: {len(course_log)} records, {len(result.reports)} observation updates; "
        f"beam geometry from {run.geometry_origin}",
        f"FastSLAM: {config.fastslam.NPARTICLES} particles, {result.resamplings} resamplings, "
        f"{len(result.landmarks)} landmarks in the best particle's map, {seconds:.2f} s" + speed,
    ]
    if result.laser_odometry is not None:
        laser = result.laser_odometry
        lines.append(
            f"Laser odometry ({matching_seconds:.1f} s): {int(laser.accepted.sum())} of "
            f"{len(laser.accepted) - 1} scan-to-scan matches accepted; "
            "intervals without odometry records (matched by correlative search): "
            f"{int((~laser.had_odometry[1:]).sum())}"
        )
    lines += notes
    glitches = run.glitch_line(config.odometry.jump_tolerance)
    if glitches:
        lines.append(glitches)
    checks = slam_report.consistency(result)
    lines.append(
        f"Map consistency: {checks['reobserved']} of {checks['landmarks']} landmarks re-observed "
        f"(median {checks['median_observations']:.0f} observations each), the nearest two "
        f"{checks['nearest_landmarks_m']:.3f} m apart; largest path step between records "
        f"{checks['largest_path_step_m']:.3f} m"
    )
    return lines


def _given_convention_warning(run: LoadedRun, config: SlamConfig) -> str | None:
    """A warning when the beam convention the settings give fits the log's scans clearly worse
    than another (``convention_warning``); None otherwise, or when a sidecar recorded it."""
    if not convention_given(config.sensor) or run.geometry_from_sidecar or run.log.is_scan.sum() < 2:
        return None
    corners = config.corners
    return convention_warning(
        run.log, run.geometry, corners.min_range, corners.max_range, config.odometry.jump_tolerance
    )


def _uncertainty_lines(nis: dict, nees: dict | None, nis_by_kind: dict[str, dict]) -> list[str]:
    """Is the stated uncertainty right: NIS always (with its mean per kind of observation when there
    are several kinds: which part of the observation model is off), NEES with truth, and what they mean."""

    def described(summary: dict, bound: float, consistent: int) -> str:
        if not summary["count"]:
            return "undefined"
        return (
            f"mean {summary['mean']:.2f}, median {summary['median']:.2f}, {100 * summary['inside_95']:.0f} % "
            f"inside the 95 % bound {bound:.2f} (consistent: {consistent})"
        )

    line = f"Uncertainty: NIS of {nis['count']} associated observations {described(nis, OBSERVATION_BOUND_95, 2)}"
    if nees is not None:
        line += f"; pose NEES {described(nees, POSE_BOUND_95, 3)}"
    lines = [line]
    if len(nis_by_kind) > 1:
        kinds = ", ".join(f"{kind} {summary['mean']:.2f} ({summary['count']})" for kind, summary in nis_by_kind.items())
        lines.append(f"  NIS mean by kind of observation (count): {kinds}")
    return [*lines, "  " + EXPLANATION]


def _score_lines(run: LoadedRun, result: SlamResult, score, match_radius: float) -> list[str]:
    """The error table against the truth and the map's errors."""
    scored = (
        "at the scans (laser odometry: no pose between scans)"
        if result.laser_odometry is not None
        else "at every record"
    )
    lines = [
        f"Errors against {run.truth_label}, {scored}: ATE [m] (aligned: after the best rigid motion), RPE over "
        f"{RPE_DISTANCE} m of path [m, rad], NEES of the mean pose (consistent: 3):",
        score.markdown(),
    ]
    if not len(run.true_corners):
        return lines + ["Map: no true corners beside the log, the map is not scored"]
    for name, errors in score.map_errors.items():
        lines.append(
            f"Map ({name}): {errors['matched']} landmarks within {match_radius:g} m of a true one, "
            f"RMSE {errors['rmse']:.4f} m, precision {errors['precision']:.2f}, recall {errors['recall']:.2f}"
        )
    return lines
