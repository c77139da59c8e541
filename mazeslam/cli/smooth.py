"""``mazeslam smooth``: the batch least-squares optimum of a log, its outputs, and the optimum beside a
filter run (``mazeslam slam`` and sweeps report the filter's ratio to it). The config's ``[map] kind``
says which (the config that fits the log's kind when none is given, as for ``mazeslam slam``):

* ``grid``: the pose graph of the scans (``mazeslam.smoothing.laser_optimum``: the laser odometry and
  loop closures, solved robustly), the map its poses draw, and a figure of the graph over it;
* ``landmarks``: corner landmarks and poses by least squares (``mazeslam.smoothing.smoother``).

Association of the corner smoother, which landmark each corner is, comes from outside it:

* ``known``: the true corner within ``[evaluation] match_radius`` of where the true pose puts the
  observation (``slam.truth_identities``); simulated and referenced logs with a map of corners;
* ``from-run``: a FastSLAM run's final map. Each scan's corners are placed in the world by the run's
  mean pose at that scan (``trajectory.csv``) and named by the nearest landmark of its ``map.json``
  within ``match_radius``; farther ones are left out. This re-associates after the fact: the filter's
  own choices are not saved, the map is the best particle's at the end, and the mean path is not that
  particle's history, so an observation made before a loop closed can fall to a neighbouring landmark
  or outside the radius.

Noise: the config's ``[fastslam]`` settings (the filter's own model), corners by its ``[corners]``;
odometry records the filter leaves out as glitches (``[odometry] jump_tolerance``) move nothing here either.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import click
import numpy as np

from mazeslam.cli.options import beam_geometry_options, geometry_overrides
from mazeslam.cli.run_folders import SMOOTH_FILES, check_same_log, default_out_dir, output_folder
from mazeslam.cli.smooth_laser import laser_smooth_lines
from mazeslam.core.beams import SensorOverrides
from mazeslam.core.motion import dead_reckoning
from mazeslam.core.outputs import staged_outputs, write_json
from mazeslam.data import sidecars
from mazeslam.data.beam_detection import loaded_with_convention
from mazeslam.data.loaded_run import LoadedRun
from mazeslam.data.scans import scan_points_world
from mazeslam.evaluation.consistency import POSE_BOUND_95, nees_summary, summary_words
from mazeslam.evaluation.metrics import align_se2, apply_se2, map_error, normalized_estimation_error
from mazeslam.evaluation.scoring import DEAD_RECKONING, error_table
from mazeslam.fastslam.identities import truth_identities
from mazeslam.pipeline import SlamConfig
from mazeslam.pipeline.config import MapKind
from mazeslam.pipeline.log_kinds import settings_for
from mazeslam.smoothing.optimum import OPTIMUM, Smoothed, from_run_identities, smooth_run
from mazeslam.viz.smooth_figure import plot_smoothed


@click.command()
@click.argument("log_file", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option(
    "--config",
    "config_path",
    type=click.Path(exists=True, dir_okay=False, path_type=Path),
    help="The slam TOML: [map] kind = grid smooths a pose graph of the scans ([scan_matching], [posegraph], "
    "[grid.grid]), landmarks the corners ([fastslam] noise, [corners]) [default: the config that fits the "
    "log's kind, as for `mazeslam slam`].",
)
@click.option(
    "--association",
    type=click.Choice(["known", "from-run"]),
    help="Smooth the corners, named by: known (the default for a corner config) the true corners (truth and "
    "map sidecars); from-run the map of a `mazeslam slam` run. A grid config without it smooths a pose graph.",
)
@click.argument("run_dir", required=False, type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.option(
    "--out",
    "out_dir",
    type=click.Path(file_okay=False, path_type=Path),
    help="Folder for trajectory.csv, map.json, smooth.png (a pose graph also occupancy.pgm/.yaml) [default: "
    "runs/<log name>/smooth/ under the current directory, unless it holds the run of another log of that name]; "
    "a run replaces the last run's files once all of its own are written (a run that fails leaves them as they "
    "were).",
)
@beam_geometry_options
def smooth(log_file, config_path, association, run_dir, out_dir, first_beam_angle, beam_direction, mount_x):
    """Batch least-squares SLAM over the whole log: the optimum the filters are measured against.

    A grid config ([map] kind = "grid") smooths a pose graph of the scans with loop closures; a corner
    config, or --association, the corners and poses. With --association from-run, RUN_DIR is the
    output folder of `mazeslam slam` on the same log."""
    if (association == "from-run") != (run_dir is not None):
        raise click.UsageError("RUN_DIR goes with --association from-run, and only with it")
    given = out_dir is not None
    out_dir = out_dir or default_out_dir(log_file, "smooth")
    if run_dir is not None and out_dir.resolve() == run_dir.resolve():
        raise click.UsageError("--out is RUN_DIR: the smoother would replace the run it reads; give another folder")
    overrides = geometry_overrides(first_beam_angle, beam_direction, mount_x)
    with output_folder(out_dir) as out_dir:
        if not given:  # a/run.log and b/run.log both default to runs/run/smooth
            check_same_log(out_dir, log_file, "smooth")
        lines = run_smooth_command(log_file, config_path, out_dir, association, run_dir, overrides, say=click.echo)
    click.echo("\n".join(lines))
    click.echo(f"results in {out_dir}")


def run_smooth_command(
    log_file,
    config_path,
    out_dir,
    association: str | None = None,
    run_dir=None,
    sensor: SensorOverrides | None = None,
    say=None,
) -> list[str]:
    """Smooth, write ``out_dir``/{trajectory.csv, trajectory.tum, map.json, smooth.png} and, for a grid
    config, occupancy.pgm/.yaml (replacing the last run's files once all are written:
    ``staged_outputs``); return the lines to print. ``association`` smooths the corners, named by
    "known" (the truth's corners; the default for a corner config) or "from-run" (``run_dir``'s map);
    a grid config without it smooths the pose graph of the scans. Without ``config_path``, the
    config that fits the log's kind (``settings_for``; the line saying so to ``say`` at once when given)."""
    config, chosen = settings_for(log_file, config_path)
    if say is not None and chosen is not None:
        say(chosen)
        chosen = None
    config = config.with_sensor(sensor)
    run = loaded_with_convention(log_file, config, cache_folder=Path(out_dir))
    if config.map.kind == MapKind.GRID and association is None:
        return [line for line in [chosen] if line] + laser_smooth_lines(run, config, Path(out_dir))
    association = association or "known"
    radius = config.evaluation.match_radius
    if association == "known":
        if run.truth is None or not len(run.true_corners):
            raise ValueError(
                f"{run.path}: --association known needs the truth and map sidecars with the true corners "
                f"({run.name}.truth.csv, {run.name}.map.json); use --association from-run RUN_DIR, or a grid "
                "config (--config configs/carmen.toml) for a pose graph of the scans"
            )
        identify, how = truth_identities(run, radius), f"known: the true corner within {radius:g} m"
    else:
        identify = from_run_identities(run, run_dir, radius)
        how = f"from the run {run_dir}: its map's nearest landmark within {radius:g} m"
    smoothed = smooth_run(run, config, identify)
    result = smoothed.result
    lines = [
        (
            f"{run.path}: {len(result.poses)} scan poses, {len(result.landmarks)} landmarks, "
            f"association {how}; beam geometry: {run.geometry_origin}"
        ),
        (
            f"Batch optimum: {result.iterations} iterations "
            f"({'converged' if result.converged else 'NOT converged'}), "
            f"{smoothed.seconds:.2f} s; chi2 {result.chi2:.1f} over {result.dof} degrees of freedom, chi2/dof "
            f"{result.chi2_per_dof:.2f} (1: the noise model fits the residuals; below: it overstates the noise)"
        ),
    ]
    document = {
        "frame": "world; metres",
        "source": str(log_file),
        "association": how,
        "landmark_ids": result.landmark_ids.tolist(),
        "landmarks": result.landmarks.round(6).tolist(),
        "landmark_covariances": result.landmark_covariances.tolist(),
        "chi2": result.chi2,
        "dof": result.dof,
        "chi2_per_dof": result.chi2_per_dof,
        "iterations": result.iterations,
        "converged": result.converged,
        "scans": len(result.poses),
        "seconds": smoothed.seconds,
        "parameters": dataclasses.asdict(config),
    }
    if run.truth is not None:
        errors, error_lines = _errors(run, run.truth, smoothed, radius)
        document.update(errors)
        lines += error_lines
    else:
        lines.append("no ground truth beside the log: no errors to report")
    with staged_outputs(out_dir, SMOOTH_FILES) as staging:
        paths = _write_outputs(staging, run, config, smoothed, document)
    lines.append("wrote " + ", ".join(str(Path(out_dir) / path.name) for path in paths.values()))
    return [line for line in [chosen] if line] + lines


def _errors(run: LoadedRun, truth: np.ndarray, smoothed: Smoothed, radius: float) -> tuple[dict, list[str]]:
    """ATE at every record against dead reckoning, NEES at the scans, map errors against ``truth``
    (``run.truth``): for map.json and to print."""
    result = smoothed.result
    table = error_table({DEAD_RECKONING: dead_reckoning(run.log, run.start_pose), OPTIMUM: smoothed.poses}, truth)
    nees = nees_summary(normalized_estimation_error(result.poses, result.pose_covariances, truth[result.scan_records]))
    aligned = (
        apply_se2(align_se2(smoothed.poses, truth), result.landmarks) if len(result.landmarks) else result.landmarks
    )
    map_errors = {
        "as estimated": map_error(result.landmarks, run.true_corners, radius),
        "aligned": map_error(aligned, run.true_corners, radius),
    }
    lines = [
        (
            f"Errors against {run.truth_label} at every record: ATE [m] (aligned: after the best rigid motion), "
            "RPE [m, rad]:"
        ),
        table.to_markdown(floatfmt=".4f"),
        f"Pose NEES at the {nees['count']} scans: {summary_words(nees, POSE_BOUND_95, 3)}",
    ]
    if len(run.true_corners):
        errors = map_errors["as estimated"]
        lines.append(
            f"Map: {errors['matched']} landmarks within {radius:g} m of a true one, "
            f"RMSE {errors['rmse']:.4f} m (aligned {map_errors['aligned']['rmse']:.4f} m)"
        )
    return {"ate": table.reset_index().to_dict(orient="records"), "nees": nees, "map_error": map_errors}, lines


def _write_outputs(out_dir: Path, run: LoadedRun, config: SlamConfig, smoothed: Smoothed, document: dict) -> dict:
    """trajectory.csv (with covariances), trajectory.tum, map.json (strict JSON) and smooth.png."""
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = {"trajectory": out_dir / "trajectory.csv", "tum": out_dir / "trajectory.tum", "map": out_dir / "map.json"}
    sidecars.write_trajectory(paths["trajectory"], run.log.times, smoothed.poses, smoothed.covariances)
    sidecars.write_tum(paths["tum"], run.log.times, smoothed.poses)
    write_json(paths["map"], document)
    points = scan_points_world(
        run.log, smoothed.poses, run.geometry, config.corners.min_range, config.corners.max_range
    )
    paths["figure"] = plot_smoothed(out_dir / "smooth.png", run, smoothed, points)
    return paths
