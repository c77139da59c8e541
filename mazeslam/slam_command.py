"""``mazeslam slam``: run the filter on a log file, write its outputs, and say how it did."""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path

from mazeslam import log, sidecars
from mazeslam.beam_detection import convention_warning
from mazeslam.config import jsonable
from mazeslam.evaluation import slam_report
from mazeslam.scans import resolve_geometry
from mazeslam.slam import load_slam_config, slam_on_file, start_pose


#: About how many frames ``--animate`` draws, whatever the log's length.
ANIMATION_FRAMES = 150


def run_slam_command(log_file, config_path, out_dir, filter_changes: dict | None = None, geometry_overrides=None,
                     animate=False, progress=True) -> list[str]:
    """Run, write ``out_dir``/{trajectory.csv, best_trajectory.csv, map.json, slam.png[, slam.gif]};
    return the lines to print. ``filter_changes`` replace ``[fastslam]`` settings (None: keep)."""
    config = load_slam_config(config_path)
    changes = {k: v for k, v in (filter_changes or {}).items() if v is not None}
    if changes:
        config = dataclasses.replace(config, fastslam=dataclasses.replace(config.fastslam, **changes))
    sensor = {k: v for k, v in (geometry_overrides or {}).items() if v is not None}
    if sensor:
        config = dataclasses.replace(config, sensor=dataclasses.replace(config.sensor, **sensor))
    course_log = log.read(log_file)
    geometry, origin = resolve_geometry(log_file, config.sensor.as_dict())
    start = start_pose(log_file)
    updates = int(course_log.is_scan.sum() + course_log.is_landmark.sum())
    every = max(1, updates // ANIMATION_FRAMES) if animate else 0  # frames for the GIF, at most ~ANIMATION_FRAMES
    began = time.perf_counter()
    result = slam_on_file(log_file, config, progress, snapshot_every=every)
    matching_seconds = time.perf_counter() - began - result.step_seconds.sum()
    lines = [f"{log_file}: {len(course_log)} records, {len(result.reports)} observation updates; beam geometry from {origin}",
             f"FastSLAM: {config.fastslam.NPARTICLES} particles, {result.resamplings} resamplings, "
             f"{len(result.landmarks)} landmarks in the best particle's map, "
             f"{result.step_seconds.sum():.2f} s" + (f" ({course_log.duration / max(result.step_seconds.sum(), 1e-9):.0f}x real time)"
                                                     if course_log.duration > 0 else " (the log's timestamps span no time)")]
    if result.laser_odometry is not None:
        laser = result.laser_odometry
        lines.append(f"Laser odometry ({matching_seconds:.1f} s): {int(laser.accepted.sum())} of {len(laser.accepted) - 1} "
                     "scan-to-scan matches accepted; intervals without odometry records (matched by correlative search): "
                     f"{int((~laser.had_odometry[1:]).sum())}")
    if not origin.startswith("sidecar") and course_log.is_scan.sum() > 1:
        warning = convention_warning(course_log, geometry, config.corners.min_range, config.corners.max_range,
                                     config.odometry.jump_tolerance)
        if warning:
            lines.append(warning)
    match_radius = config.evaluation.match_radius
    if result.dropped_odometry:
        lines.append(f"left out {len(result.dropped_odometry)} odometry records travelling more than "
                     f"{config.odometry.jump_tolerance:g} m in one step (glitches): "
                     + ", ".join(f"line {course_log.line_numbers[r.index]} (t {r.t:.3f} s, dX {r.distance:+.4f} m, "
                                 f"dTheta {r.turn:+.4f} rad)" for r in result.dropped_odometry))
    checks = slam_report.consistency(result)
    lines.append(f"Map consistency: {checks['reobserved']} of {checks['landmarks']} landmarks re-observed "
                 f"(median {checks['median_observations']:.0f} observations each), the nearest two "
                 f"{checks['nearest_landmarks_m']:.3f} m apart; largest path step between records "
                 f"{checks['largest_path_step_m']:.3f} m")
    evaluation = slam_report.evaluate_against_truth(log_file, course_log, result, start, match_radius)
    world = sidecars.read_map(sidecars.map_path(log_file)) if sidecars.map_path(log_file).exists() else {}
    extra = {"source": str(log_file), "beam_geometry": geometry.to_dict(), "start_pose": start.tolist(),
             "parameters": jsonable(dataclasses.asdict(config)), "consistency": checks,
             "dropped_odometry_lines": [int(course_log.line_numbers[r.index]) for r in result.dropped_odometry]}
    if evaluation is not None:
        table, map_errors = evaluation
        scored = "at the scans (laser odometry: no pose between scans)" if result.laser_odometry is not None else "at every record"
        against = world.get("truth_kind", "ground truth")
        lines += [f"Errors against {against}, {scored}: ATE [m] (aligned: after the best rigid motion), RPE over "
                  f"{slam_report.RPE_DISTANCE} m of path [m, rad], NEES of the pose (consistent: 3):",
                  table.to_markdown(floatfmt=".4f")]
        truth_tum = Path(out_dir) / "truth.tum"
        has_corners = len(world.get("corners", [])) > 0
        if not has_corners:
            lines.append("Map: no true corners beside the log, the map is not scored")
        for name, errors in map_errors.items() if has_corners else ():
            lines.append(f"Map ({name}): {errors['matched']} landmarks within {match_radius:g} m of a true one, "
                         f"RMSE {errors['rmse']:.4f} m, precision {errors['precision']:.2f}, recall {errors['recall']:.2f}")
        extra["ate"] = table.reset_index().to_dict(orient="records")
        extra["map_error"] = map_errors
    else:
        lines.append("no ground truth beside the log: no errors to report")
    paths = slam_report.write_outputs(out_dir, result, extra)
    if evaluation is not None:
        sidecars.write_tum(truth_tum, *sidecars.read_truth(sidecars.truth_path(log_file)))
        paths["truth_tum"] = truth_tum
    truth = sidecars.read_truth(sidecars.truth_path(log_file))[1] if evaluation is not None else None
    points = slam_report.scan_points_world(course_log, result.mean_poses, geometry, config.corners.min_range,
                                           config.corners.max_range)
    walls = world.get("walls")
    paths["figure"] = slam_report.plot_slam(Path(out_dir) / "slam.png", result, points, truth, walls,
                                            title=f"{Path(log_file).name}: FastSLAM, {config.fastslam.NPARTICLES} particles",
                                            true_landmarks=world.get("corners"),
                                            truth_label=_truth_label(world))
    if animate:
        paths["animation"] = slam_report.animate_slam(Path(out_dir) / "slam.gif", result, points, truth, walls)
    lines.append("wrote " + ", ".join(str(p) for p in paths.values()))
    return lines



def _truth_label(world: dict) -> str:
    """How a figure names the path of the truth sidecar: a reference (CARMEN's corrected poses) or the true path."""
    return "reference path" if world.get("truth_kind", "").startswith("reference") else "true path"
