"""Every file of a SLAM run, for both filters: ``write_run`` writes what ``mazeslam slam`` writes.

The run's data (``trajectory.csv``, ``best_trajectory.csv``, ``map.json``, ``*.tum``, a grid's
``occupancy.*``: ``mazeslam.pipeline.outputs.write_outputs``), its figure ``slam.png`` (corner
FastSLAM: the exercise's figure, with its map exported as ``occupancy.*`` and ``landmarks.csv``;
the grid filter: its map with the paths and particles) and, when asked, its animation (``slam.mp4``
with ffmpeg, else ``slam.gif``). The slam command draws corner FastSLAM's figure in a side process
while it scores the run (``landmark_figure_call``); from Python ``write_run`` draws everything.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from mazeslam.core.outputs import WriteError
from mazeslam.data import sidecars
from mazeslam.data.loaded_run import LoadedRun
from mazeslam.data.scans import scan_points_world
from mazeslam.pipeline import MapKind, SlamConfig, SlamResult
from mazeslam.pipeline.outputs import write_outputs


def figure_title(run: LoadedRun, config: SlamConfig) -> str:
    """The run's figures' title: the log, the filter and its particles."""
    return f"{run.path.name}: {config.map.kind.filter_name}, {config.particles} particles"


def trusted_span(config: SlamConfig) -> tuple[float, float]:
    """The ranges (m) of the scan returns the run's filter uses, (min, max): the grid's or the corners'."""
    if config.map.kind == MapKind.GRID:
        return config.grid.grid.min_range, config.grid.grid.max_range
    return config.corners.min_range, config.corners.max_range


def landmark_figure_call(
    out_dir: Path, run: LoadedRun, config: SlamConfig, result: SlamResult
) -> tuple[Callable, tuple]:
    """What draws corner FastSLAM's ``slam.png`` and exports its map into ``out_dir``, as a function
    and its (picklable) arguments, for a side process to run (``draw_and_export``); it returns the
    paths written by name."""
    from mazeslam.viz.slam_figure import SlamFigure, draw_and_export

    span = trusted_span(config)
    points = scan_points_world(run.log, result.mean_poses, run.geometry, *span)
    figure = SlamFigure.of(
        result,
        points,
        truth=run.truth,
        walls=run.walls,
        true_landmarks=run.true_corners if run.world is not None else None,
        title=figure_title(run, config),
        truth_label=run.truth_path_label,
    )
    return draw_and_export, (out_dir, figure, run.log, run.geometry, *span)


def write_run(
    out_dir: str | Path,
    run: LoadedRun,
    config: SlamConfig,
    result: SlamResult,
    facts: dict | None = None,
    animate: bool = False,
    progress: bool = False,
    drawn: dict[str, Path] | None = None,
) -> dict[str, Path]:
    """Write every file of ``result`` (a run of ``config`` over ``run``) into ``out_dir``; returns
    the paths by name.

    Args:
        facts: more of ``map.json`` (source, scores, ...; ``write_outputs``).
        animate: also the animation; the run must have kept snapshots (``run_slam(snapshot_every=...)``).
        progress: a progress bar for the animation.
        drawn: corner FastSLAM's figure and map export when something else drew them
            (``landmark_figure_call``, in the slam command's side process); else they are drawn here.
    """
    out_dir = Path(out_dir)
    paths = write_outputs(out_dir, result, facts or {})
    if run.truth is not None:
        paths["truth_tum"] = out_dir / "truth.tum"
        sidecars.write_tum(paths["truth_tum"], run.log.times, run.truth)
    if result.grid is not None:
        from mazeslam.viz.grid_figure import plot_grid_run, plot_occupancy

        occupancy = result.occupancy
        assert occupancy is not None
        paths["occupancy_figure"] = plot_occupancy(out_dir / "occupancy.png", occupancy, figure_title(run, config))
        paths["figure"] = plot_grid_run(
            out_dir / "slam.png",
            occupancy,
            result.mean_poses,
            result.best_poses,
            result.filter.poses,
            figure_title(run, config),
            run.truth,
            run.truth_path_label,
        )
    elif drawn is None:
        function, arguments = landmark_figure_call(out_dir, run, config, result)
        paths.update(function(*arguments))
    else:
        paths.update(drawn)
    if animate:
        paths["animation"] = write_animation(out_dir, run, config, result, progress)
    return paths


def write_animation(out_dir: Path, run: LoadedRun, config: SlamConfig, result: SlamResult, progress: bool) -> Path:
    """The run as an animation (``slam.mp4`` with ffmpeg, else ``slam.gif``) from its snapshots: corner
    FastSLAM's particles, landmarks and scans (``animate_slam``), or the grid filter's map growing
    (``animate_grid``). An error of the video writer names the file it writes."""
    from mazeslam.viz.slam_view import ffmpeg_path

    try:
        return _animate(out_dir, run, config, result, progress)
    except OSError as error:  # the video writer names no file
        name = "slam.mp4" if ffmpeg_path() is not None else "slam.gif"
        raise WriteError(out_dir / name, error.strerror or str(error)) from error


def _animate(out_dir: Path, run: LoadedRun, config: SlamConfig, result: SlamResult, progress: bool) -> Path:
    title, truth_label = figure_title(run, config), run.truth_path_label
    if result.grid is not None:
        from mazeslam.viz.grid_animation import animate_grid

        records = result.estimated_records
        truth = run.truth[records] if run.truth is not None else None
        return animate_grid(
            out_dir / "slam.gif",
            result.snapshots,
            result.mean_poses[records],
            title,
            truth,
            truth_label,
            progress=progress,
        )
    from mazeslam.features.corners import CornerExtractor
    from mazeslam.viz.slam_figure import animate_slam
    from mazeslam.viz.slam_view import scan_source

    extractor = CornerExtractor(run.geometry, run.log.width, config.corners)
    points = scan_points_world(run.log, result.mean_poses, run.geometry, *trusted_span(config))
    return animate_slam(
        out_dir / "slam.gif",
        result,
        points,
        run.truth,
        run.walls,
        scan_at=scan_source(run.log, result.mean_poses, run.geometry, extractor) if run.log.n_beams else None,
        title=title,
        progress=progress,
        truth_label=truth_label,
    )
