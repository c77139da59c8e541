"""``mazeslam slam``: run the filter on a log file, write its outputs, and say how it did."""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path
from typing import TYPE_CHECKING

import click

from mazeslam.cli.options import (
    PARTICLES,
    POSITIVE,
    SEED,
    beam_geometry_options,
    course_log_expected,
    geometry_overrides,
)
from mazeslam.cli.run_folders import SLAM_FILES, check_same_log, default_out_dir, output_folder
from mazeslam.cli.side_process import SideProcess
from mazeslam.core.beams import SensorOverrides
from mazeslam.core.config import with_settings
from mazeslam.core.outputs import staged_outputs
from mazeslam.data.beam_detection import convention_given, convention_warning, loaded_with_convention
from mazeslam.data.loaded_run import LoadedRun
from mazeslam.evaluation.consistency import EXPLANATION, MOTION_EXPLANATION, POSE_BOUND_95, summarise, summary_words
from mazeslam.evaluation.scoring import RPE_DISTANCE, score_run
from mazeslam.evaluation.sharpness import paths_sharpness, sharpness_lines
from mazeslam.gridslam.filter import SearchMode
from mazeslam.pipeline import MapKind, SlamConfig, SlamResult, run_slam
from mazeslam.pipeline.log_kinds import settings_for
from mazeslam.pipeline.outputs import consistency
from mazeslam.viz.run_files import figure_title, landmark_figure_call, trusted_span, write_run

if TYPE_CHECKING:
    import numpy as np

    from mazeslam.viz.live import GridLiveView, LiveView

#: About how many frames ``--animate`` draws, whatever the log's length.
ANIMATION_FRAMES = 150
#: What the side process loads while the filter runs: what draws ``slam.png`` and exports the map.
FIGURE_MODULES = (
    "matplotlib.figure",
    "matplotlib.backends.backend_agg",
    "matplotlib.image",
    "mazeslam.viz.slam_figure",
    "mazeslam.data.map_export",
)


@click.command()
@click.argument("log_file", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option(
    "--particles",
    type=PARTICLES,
    help="Particle count of the filter that runs [default: from the config; without one 100 for corner FastSLAM, "
    "30 for the grid filter].",
)
@click.option(
    "--config",
    "config_path",
    type=click.Path(exists=True, dir_okay=False, path_type=Path),
    help="Slam TOML: [map] kind and the filter's settings, [fastslam] or [grid], with [corners], [sensor], "
    "[odometry], [scan_matching] [default: the file under configs/ that fits the log's kind, named in one line: "
    "course.toml for the exercise's robot, carmen.toml and mrclam.toml for imports, the defaults "
    "(fastslam.toml) for simulated mazes].",
)
@click.option(
    "--out",
    "out_dir",
    type=click.Path(file_okay=False, path_type=Path),
    help="Folder for trajectory.csv, map.json, slam.png, occupancy.pgm/.yaml [default: runs/<log name>/slam/ "
    "under the current directory, unless it holds the run of another log of that name]; a run replaces the "
    "last run's files once all of its own are written (a run that fails leaves them as they were).",
)
@click.option("--seed", type=SEED, help="Seed of the filter's random draws [default: from the config, 0].")
@click.option(
    "--association",
    type=click.Choice(["unknown", "known"]),
    help="unknown: maximum likelihood with a gate; known: the landmark records' identities.",
)
@click.option("--version", "version", type=click.Choice(["1", "2"]), help="FastSLAM 1.0 or 2.0.")
@click.option(
    "--map",
    "map_kind",
    type=click.Choice(["landmarks", "grid"]),
    help="What the particles map [default: the config's [map] kind, landmarks]: landmarks (corner FastSLAM) "
    "or grid (an occupancy grid each, gmapping's filter).",
)
@click.option(
    "--animate",
    is_flag=True,
    help="Also write the run as an animation (particles, map, current scan and corners over time): "
    "slam.mp4 when ffmpeg is available (pip install 'mazeslam[video]'), slam.gif otherwise.",
)
@click.option(
    "--live",
    is_flag=True,
    help="Show the filter as it runs in a window (particles, map, current scan and corners; the grid "
    "filter's map, path and particles) at the log's own pace (--speed), space to pause and resume; the "
    "window stays open at the end until closed. Without a display, says so (use --animate).",
)
@click.option(
    "--speed",
    type=POSITIVE,
    default=1.0,
    show_default=True,
    help="With --live: log seconds shown per second (1: the log's own pace, 10: ten times faster).",
)
@click.option(
    "--optimum",
    "optimum_dir",
    type=click.Path(exists=True, file_okay=False, path_type=Path),
    help="Grid filter: a `mazeslam smooth` output folder of the same log, the pose graph its errors are set "
    "beside [default: runs/<log name>/smooth/ when it holds one]. Corner FastSLAM's optimum is worked out here.",
)
@beam_geometry_options
@click.option("--quiet", is_flag=True, help="No progress bar.")
def slam(
    log_file,
    particles,
    config_path,
    out_dir,
    seed,
    association,
    version,
    map_kind,
    animate,
    live,
    speed,
    optimum_dir,
    first_beam_angle,
    beam_direction,
    mount_x,
    quiet,
):
    """Run SLAM on a course log: trajectory, map, figure, and errors when truth exists.

    The filter is the one the config's [map] kind names: corner FastSLAM or the grid filter."""
    overrides = geometry_overrides(first_beam_angle, beam_direction, mount_x)
    given = out_dir is not None
    filter_changes = {
        "NPARTICLES": particles,
        "seed": seed,
        "association": association,
        "version": int(version) if version else None,
    }
    with course_log_expected(log_file), output_folder(out_dir or default_out_dir(log_file, "slam")) as out_dir:
        if not given:  # a/run.log and b/run.log both default to runs/run/slam
            check_same_log(out_dir, log_file, "slam")
        lines = run_slam_command(
            log_file,
            config_path,
            out_dir,
            filter_changes,
            overrides,
            animate,
            not quiet,
            live=live,
            speed=speed,
            echo=lambda message: click.echo(message, err=True),
            map_kind=map_kind,
            side_process=True,
            say=click.echo,
            optimum_dir=optimum_dir or default_out_dir(log_file, "smooth"),
        )
    click.echo("\n".join(lines))
    click.echo(f"results in {out_dir}")


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
    say=None,
    speed: float = 1.0,
    optimum_dir: Path | None = None,
) -> list[str]:
    """Run, write ``out_dir``/{trajectory.csv, best_trajectory.csv, map.json, slam.png, occupancy.pgm/.yaml/.png,
    landmarks.csv[, slam.gif]}, replacing the last run's files (``SLAM_FILES``) once all are written
    (``staged_outputs``: an error or interrupt leaves them as they were); return the lines to print.
    ``filter_changes`` replace ``[fastslam]`` settings and ``sensor`` the ``[sensor]`` ones (None
    values: keep the config's). ``live``: draw the filter as it runs (``mazeslam.viz.live``) at
    ``speed`` times the log's pace; its notes (no window; the window waiting to be closed) go to
    ``echo`` at once, and to the lines.
    ``map_kind`` replaces ``[map] kind``; the particle count and seed go to the filter that runs.
    ``side_process``: corner FastSLAM's ``slam.png`` and map export are made by a ``SideProcess``
    forked before the filter runs, which loads matplotlib meanwhile and draws while this process
    scores the run and writes the rest (the command line's way; otherwise they are made here).
    Without ``config_path``, the config that fits the log's kind runs (``settings_for``); the line
    saying which goes to ``say`` at once when given, else to the lines. ``optimum_dir``: the
    ``mazeslam smooth`` folder whose pose graph of the log a grid run with truth is set beside, when
    it holds one (corner FastSLAM's optimum is worked out here)."""
    config, chosen = settings_for(log_file, config_path)
    if say is not None and chosen is not None:
        say(chosen)
        chosen = None
    filter_changes = filter_changes or {}
    changes = {"map.kind": map_kind, **{f"fastslam.{name}": value for name, value in filter_changes.items()}}
    changes.update({"grid.particles": filter_changes.get("NPARTICLES"), "grid.seed": filter_changes.get("seed")})
    config = with_settings(config, changes)
    config = config.with_sensor(sensor)
    run = loaded_with_convention(log_file, config, cache_folder=Path(out_dir))
    notes = [note for note in [chosen, _given_convention_warning(run, config), _blind_motion_note(run, config)] if note]
    grid = config.map.kind == MapKind.GRID
    unused = [f"--{name}" for name in ("association", "version") if filter_changes.get(name) is not None]
    if grid and unused:
        notes.append(
            f"note: {' and '.join(unused)} set corner FastSLAM's [fastslam]; the grid filter runs ([map] kind)"
        )
    graph_poses = _pose_graph(run, optimum_dir) if grid else None  # read first: a wrong folder fails at once
    # The side process ends (its drawing stopped) before the staging folder is committed or removed.
    with (
        staged_outputs(out_dir, SLAM_FILES) as staging,
        SideProcess(FIGURE_MODULES, fork=side_process and not grid) as side,
    ):
        live_speed = speed if live else None
        lines, paths = _run_and_write(
            log_file, run, config, staging, notes, animate, progress, live_speed, echo, side, graph_poses
        )
    return [*lines, "wrote " + ", ".join(str(Path(out_dir) / path.name) for path in paths.values())]


def _run_and_write(
    log_file,
    run: LoadedRun,
    config: SlamConfig,
    out_dir: Path,
    notes: list[str],
    animate,
    progress,
    live_speed: float | None,
    echo,
    side,
    graph_poses: np.ndarray | None = None,
) -> tuple[list[str], dict[str, Path]]:
    """``run_slam_command`` once the settings and the log are read: the filter, its outputs written
    into ``out_dir`` (the staging folder) and the lines to print, with the paths written by name;
    ``side`` (a ``SideProcess``) draws corner FastSLAM's figure and exports its map; ``live_speed``:
    the live view's speed (None: no live view)."""
    grid = config.map.kind == MapKind.GRID
    title = figure_title(run, config)
    updates = int(run.log.is_scan.sum() + (0 if grid else run.log.is_landmark.sum()))
    every = max(1, updates // ANIMATION_FRAMES) if animate else 0  # at most ~ANIMATION_FRAMES frames
    view: LiveView | GridLiveView | None = None
    if live_speed is not None:
        from mazeslam.viz.live import GridLiveView, LiveView

        if grid:
            view = GridLiveView(run, title, speed=live_speed)
        else:
            view = LiveView(run, config.corners, title, speed=live_speed)
        if view.message and echo is not None:
            echo(view.message)
    began = time.perf_counter()
    result = run_slam(run, config, progress, snapshot_every=every, on_update=view)
    if view is not None:
        if view.open and echo is not None:
            echo("--live: the run is done; close the window (or press q) to write its outputs")
        view.close(len(run.log) - 1, result.filter)
    matching_seconds = time.perf_counter() - began - result.step_seconds.sum()
    lines = _run_lines(run, config, result, matching_seconds, notes)
    if view is not None:
        lines.append(
            f"Live view: {view.frames} frames drawn in {view.drawing_seconds:.1f} s"
            + ("" if view.window else " (off-screen: no display)")
        )
    span = trusted_span(config)
    if not grid:  # drawn by the side process while this one scores the run
        function, arguments = landmark_figure_call(out_dir, run, config, result)
        side.start(function, *arguments)
    score = score_run(run, result, config.evaluation.match_radius)
    nis = result.nis_summary()
    nis_by_kind = {kind: summarise(values, result.nis_bound) for kind, values in sorted(result.nis_by_kind().items())}
    line_numbers = run.log.line_numbers
    assert line_numbers is not None  # the log was read from a file: each record has its line
    extra = {
        "source": str(log_file),
        "beam_geometry": run.geometry.to_dict(),
        "start_pose": run.start_pose.tolist(),
        "parameters": dataclasses.asdict(config),
        "nis": nis,
        "nis_by_kind": nis_by_kind,
        "resampled_fraction": result.resampled_fraction,
        "dropped_odometry_lines": [int(line_numbers[r.index]) for r in result.dropped_odometry],
    }
    if not grid:
        extra["consistency"] = consistency(result)
    lines += _uncertainty_lines(result, nis, score.nees_summary if score is not None else None, nis_by_kind)
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
        optimum_lines, optimum = _optimum(run, config, result, score, graph_poses)
        lines += optimum_lines
        if optimum is not None:
            extra["optimum"] = optimum
    else:
        lines.append("no ground truth beside the log: no errors to report")
    drawn = None if grid else side.result()  # slam.png and the map export
    paths = write_run(out_dir, run, config, result, extra, animate, progress, drawn)
    return lines, paths


def _pose_graph(run: LoadedRun, optimum_dir: Path | None) -> np.ndarray | None:
    """The poses (R, 3) of a ``mazeslam smooth`` run of ``run``'s log in ``optimum_dir`` (None
    without one, or without truth to score it by); an error naming the folder if it is another log's."""
    if optimum_dir is None or run.truth is None:
        return None
    from mazeslam.smoothing.optimum import smoothed_poses  # scipy.sparse: 0.3 s, for a truth's runs

    return smoothed_poses(run, optimum_dir)


def _optimum(
    run: LoadedRun, config: SlamConfig, result: SlamResult, score, graph_poses: np.ndarray | None
) -> tuple[list[str], dict | None]:
    """The filter's ratio to the optimum (``optimum_columns``) and its line: corner FastSLAM's worked
    out here, the grid filter's the pose graph ``graph_poses`` (R, 3) of a ``mazeslam smooth`` run,
    which takes longer than the filter on a building's log; without it, a line saying how to get one."""
    from mazeslam.smoothing.optimum import optimum_columns, optimum_line  # scipy.sparse: 0.3 s, for a truth's runs

    if config.map.kind == MapKind.GRID and graph_poses is None:
        return [
            f"No pose graph of this log to set the grid filter beside: `mazeslam smooth {run.path}` makes one "
            "(runs/<log name>/smooth/, or give its folder with --optimum)"
        ], None
    optimum = optimum_columns(run, config, score, graph_poses)
    return ([] if optimum is None else [optimum_line(optimum, result.filter_name)]), optimum


def _run_lines(
    run: LoadedRun, config: SlamConfig, result: SlamResult, matching_seconds: float, notes: list[str]
) -> list[str]:
    """What the run did: records, particles, resamplings, speed, laser odometry, ``notes`` (warnings), glitches."""
    course_log, seconds = run.log, result.step_seconds.sum()
    if result.grid_run is not None:
        seconds = result.grid_run.total_seconds  # its laser odometry included
    speed = (
        f" ({course_log.duration / max(seconds, 1e-9):.0f}x real time)"
        if course_log.duration > 0
        else " (the log's timestamps span no time)"
    )
    if result.grid_run is not None:
        holds = f"peak map memory {result.grid_run.peak_map_bytes / 2**20:.0f} MB (tiles shared between particles)"
    else:
        holds = f"{len(result.landmarks)} landmarks in the best particle's map"
    lines = [
        f"{run.path}: {len(course_log)} records, {int(course_log.is_scan.sum())} scans, "
        f"{result.updates} observation updates; "
        f"beam geometry: {run.geometry_origin}",
        f"{result.filter_name}: {config.particles} particles, {result.resamplings} resamplings, {holds}, "
        f"{seconds:.2f} s" + speed,
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
    glitches = run.glitch_line(config.odometry.jump_tolerance, pairs_summed=result.grid is not None)
    if glitches:
        lines.append(glitches)
    if result.grid is None:
        checks = consistency(result)
        nearest = f", the nearest two {checks['nearest_landmarks_m']:.3f} m apart" if checks["landmarks"] >= 2 else ""
        lines.append(
            f"Map consistency: {checks['reobserved']} of {checks['landmarks']} landmarks re-observed "
            f"(median {checks['median_observations']:.0f} observations each){nearest}; largest path step between "
            f"records {checks['largest_path_step_m']:.3f} m"
        )
    return lines


def _blind_motion_note(run: LoadedRun, config: SlamConfig) -> str | None:
    """A note when the grid filter maps a log of scans without odometry records by searching only
    where a match fails: its laser odometry then matches blind and can be a right angle wrong."""
    course_log = run.log
    if config.map.kind != MapKind.GRID or config.grid.search != SearchMode.FAILED_MATCH:
        return None
    if course_log.is_odometry.any() or not course_log.is_scan.any():
        return None
    return (
        f"note: {run.path.name} has no odometry records, so the laser odometry matches each scan blind; "
        '[grid] search = "every-scan" (configs/carmen_without_odometry.toml for CARMEN logs) searches '
        "every scan against the map for its wrong turns"
    )


def _given_convention_warning(run: LoadedRun, config: SlamConfig) -> str | None:
    """A warning when the beam convention the settings give fits the log's scans clearly worse
    than another (``convention_warning``); None otherwise, or when a sidecar recorded it."""
    if not convention_given(config.sensor) or run.geometry_from_sidecar or run.log.is_scan.sum() < 2:
        return None
    corners = config.corners
    return convention_warning(
        run.log, run.geometry, corners.min_range, corners.max_range, config.odometry.jump_tolerance
    )


def _uncertainty_lines(result: SlamResult, nis: dict, nees: dict | None, nis_by_kind: dict[str, dict]) -> list[str]:
    """Is the stated uncertainty right: NIS always (corner FastSLAM's observations, with its mean per
    kind of observation when there are several kinds: which part of the observation model is off;
    the grid filter's scan-match corrections of the motion), NEES with truth, and what they mean."""

    if result.grid is not None:
        what = f"motion NIS of {nis['count']} matched scans"
        hint = (
            "  far less than 3: [grid] motion_noise is wider than the corrections the scan matches make, "
            "far more: narrower"
        )
    else:
        what, hint = f"NIS of {nis['count']} associated observations", None
    line = f"Uncertainty: {what} {summary_words(nis, result.nis_bound, result.nis_dof)}"
    if nees is not None:
        line += f"; pose NEES {summary_words(nees, POSE_BOUND_95, 3)}"
    lines = [line]
    if hint:
        lines.append(hint)
    if len(nis_by_kind) > 1:
        kinds = ", ".join(f"{kind} {summary['mean']:.2f} ({summary['count']})" for kind, summary in nis_by_kind.items())
        lines.append(f"  NIS mean by kind of observation (count): {kinds}")
    return [*lines, "  " + (MOTION_EXPLANATION if result.grid is not None else EXPLANATION)]


def _score_lines(run: LoadedRun, result: SlamResult, score, match_radius: float) -> list[str]:
    """The error table against the truth and the map's errors."""
    scored = (
        "at every record"
        if result.laser_odometry is None and result.grid is None
        else "at the scans (the filter estimates no pose of its own between scans)"
    )
    lines = [
        f"Errors against {run.truth_label}, {scored}: ATE [m] (aligned: after the best rigid motion), RPE over "
        f"{RPE_DISTANCE} m of path [m, rad], NEES of the mean pose (consistent: 3):",
        score.markdown(),
    ]
    if result.grid is not None:
        return lines
    if not len(run.true_corners):
        return lines + ["Map: no true corners beside the log, the map is not scored"]
    for name, errors in score.map_errors.items():
        lines.append(
            f"Map ({name}): {errors['matched']} landmarks within {match_radius:g} m of a true one, "
            f"RMSE {errors['rmse']:.4f} m, precision {errors['precision']:.2f}, recall {errors['recall']:.2f}"
        )
    return lines
