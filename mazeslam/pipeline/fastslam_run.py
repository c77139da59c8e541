"""Corner FastSLAM over a whole log: odometry records predict, scan records extract corners and update.

This is the exercise's main loop (fastslam1_sim.m): for every line of the log, an odometry entry
moves the particles, a laser entry is turned into corner observations that weigh and correct them.
With laser odometry (``[scan_matching] enabled``), the particles move at each scan by the scan's
match to the one before instead, and odometry records only inform that match.
"""

from __future__ import annotations

import math
import time

import numpy as np

from mazeslam.core.beams import EXERCISE_CONVENTION, BeamGeometry
from mazeslam.core.motion import dead_reckoning
from mazeslam.data import log
from mazeslam.data.loaded_run import LoadedRun
from mazeslam.fastslam.filter import Association, FastSLAM, FastSLAMParams, FilterDivergence
from mazeslam.fastslam.identities import truth_identities
from mazeslam.features.corners import CornerExtractor, CornerParams
from mazeslam.pipeline.config import MapKind, SlamConfig
from mazeslam.pipeline.result import SlamResult
from mazeslam.registration.scan_matching import LaserOdometry, laser_odometry


def run_fastslam(
    course_log: log.CourseLog,
    params: FastSLAMParams | None = None,
    corner_params: CornerParams | None = None,
    geometry: BeamGeometry = EXERCISE_CONVENTION,
    start_pose=(0.0, 0.0, 0.0),
    progress: bool = True,
    snapshot_every: int = 0,
    jump_tolerance: float = math.inf,
    identify=None,
    laser: LaserOdometry | None = None,
    on_update=None,
) -> SlamResult:
    """FastSLAM over every record of ``course_log``; odometry records travelling more than
    ``jump_tolerance`` metres are left out (listed in ``SlamResult.dropped_odometry``).

    With ``laser`` (the log's laser odometry) the particles move by its increment at each scan and
    odometry records move nothing.

    ``identify(record_index, observations (K, 2)) -> ids (K,)`` names the landmark each scan
    observation is (for ``association="known"`` on scan logs; landmark records carry their own).

    ``on_update(record_index, filter)``, when given, is called after every observation update (for
    a live view: ``mazeslam.viz.live``); it must not change the filter.
    """
    params = params or FastSLAMParams()
    _check_landmark_noise(course_log, params)
    slam = FastSLAM(params, start_pose)
    extractor = CornerExtractor(geometry, course_log.width, corner_params) if course_log.n_beams else None
    count = len(course_log)
    mean_poses, best_poses, step_seconds = np.empty((count, 3)), np.empty((count, 3)), np.empty(count)
    pose_covariances = np.empty((count, 3, 3))
    reports, snapshots, dropped = [], [], []
    observation_kinds: list[list[str]] = []
    records = list(course_log.records())
    laser_increments = dict(zip(laser.scan_records, laser.increments)) if laser is not None else {}
    bar = None
    if progress:  # tqdm only when drawn: it takes 0.06 s to import
        from tqdm.auto import tqdm

        bar = tqdm(total=count, desc="FastSLAM", unit="record")
    position = 0
    while position < count:
        record = records[position]
        started = time.perf_counter()
        done: list[log.OdometryRecord | log.ScanRecord | log.LandmarkRecord]
        moved = True  # the filter changed: its statistics are computed again (else the last ones hold)
        if isinstance(record, log.OdometryRecord):
            # No motion, or laser odometry (its increment at the next scan holds this motion): no change.
            moved = laser is None and (record.distance != 0 or record.turn != 0)
            if moved and abs(record.distance) > jump_tolerance:
                dropped.append(record)
                moved = False
            elif moved:
                slam.predict(record.distance, record.turn)
            done = [record]
        else:
            if isinstance(record, log.ScanRecord):
                if laser is not None:
                    slam.predict_relative(laser_increments[record.index])
                done = [record]
                assert extractor is not None  # a log with scan records has beams
                z, covariances, facings, kinds = _scan_observations(extractor, record)
                ids = None
                if identify is not None:
                    ids = identify(record.index, z)
            else:  # landmark observations: all those taken at one time update together
                group = _same_time_landmarks(records, position)
                done = list(group)
                z = np.array([[r.range, r.bearing] for r in group])
                covariances, ids, facings = None, np.array([r.landmark for r in group]), None
                kinds = ["landmark"] * len(group)
            observation_kinds.append(kinds)
            try:
                report = slam.update(z, covariances, ids if params.association == Association.KNOWN else None, facings)
            except FilterDivergence as error:
                if bar is not None:  # the error is the last line, not a bar left half drawn
                    bar.leave = False
                    bar.close()
                raise error.at(_place(course_log, position)) from None
            reports.append(report)
            if snapshot_every and (len(reports) - 1) % snapshot_every == 0:
                snapshots.append((record.index, slam.poses.copy(), slam.landmarks()[0]))
            if on_update is not None:
                on_update(record.index, slam)
        if moved or position == 0:
            mean, best, spread = slam.mean_pose(), slam.poses[slam.best_particle()], slam.pose_covariance()
        for finished in done:
            mean_poses[finished.index], best_poses[finished.index] = mean, best
            pose_covariances[finished.index] = spread
            step_seconds[finished.index] = (time.perf_counter() - started) / len(done)
        position += len(done)
        if bar is not None:
            bar.update(len(done))
    if bar is not None:
        bar.close()
    landmarks, covariances = slam.landmarks()
    return SlamResult(
        kind=MapKind.LANDMARKS,
        times=course_log.times,
        mean_poses=mean_poses,
        best_poses=best_poses,
        pose_covariances=pose_covariances,
        estimated_records=laser.scan_records if laser is not None else np.arange(count),
        dead_reckoning=dead_reckoning(course_log, start_pose, [r.index for r in dropped]),
        step_seconds=step_seconds,
        landmarks=landmarks,
        landmark_covariances=covariances,
        nis=np.concatenate([report.nis for report in reports]) if reports else np.empty(0),
        nis_dof=2,
        reports=reports,
        observation_kinds=observation_kinds,
        updates=len(reports),
        resamplings=slam.resamplings,
        snapshots=snapshots,
        filter=slam,
        dropped_odometry=dropped,
        laser_odometry=laser,
    )


def _place(course_log: log.CourseLog, index: int) -> str:
    """Where record ``index`` of ``course_log`` is, for messages: the file and line, the time."""
    line = course_log.line_numbers[index] if course_log.line_numbers is not None else None
    at = f"{course_log.source}:{line}" if line is not None else f"{course_log.source}, record {index}"
    return f"{at} (t {course_log.times[index]:.3f} s)"


def _check_landmark_noise(course_log: log.CourseLog, params: FastSLAMParams) -> None:
    """Refuse, before any work, a log of landmark observations under settings that give them no
    noise: they come without a covariance of their own (unlike the corners of a scan), so
    ``[fastslam] sigmaR`` and ``sigmaB`` are their whole noise, and a zero makes every update's
    covariance singular (the defaults, measured for scans, are 0)."""
    landmarks = np.flatnonzero(course_log.is_landmark)
    if len(landmarks) and (params.sigmaR == 0 or params.sigmaB == 0):
        raise ValueError(
            f"{_place(course_log, int(landmarks[0]))}: this log's {len(landmarks)} landmark observations come "
            "without a covariance of their own, so [fastslam] sigmaR and sigmaB are their whole noise, and they "
            f"are {params.sigmaR:g} and {params.sigmaB:g} here: set both above 0 (`mazeslam calibrate` measures "
            "them against truth); a log imported from MRCLAM wants --config configs/mrclam.toml"
        )


def _scan_observations(extractor: CornerExtractor, record: log.ScanRecord):
    """Corner observations of one scan: (K, 2) range/bearing, (K, 2, 2) covariances, (K,) facings
    and their K kinds."""
    features = extractor.extract(record.ranges)
    kinds = [observation.kind for observation in features.observations]
    return features.observation_array(), features.observation_covariances(), features.observation_facings(), kinds


def _same_time_landmarks(records: list, position: int) -> list[log.LandmarkRecord]:
    """The landmark records from ``position`` on (a landmark record) that share its timestamp."""
    group: list[log.LandmarkRecord] = [records[position]]
    for record in records[position + 1 :]:
        if not isinstance(record, log.LandmarkRecord) or record.t != group[0].t:
            break
        group.append(record)
    return group


def fastslam_on_run(
    run: LoadedRun,
    config: SlamConfig,
    progress: bool = True,
    snapshot_every: int = 0,
    laser: LaserOdometry | None = None,
    on_update=None,
) -> SlamResult:
    """``run_fastslam`` on a loaded log, from its start pose with its beam geometry, with
    ``config``'s ``[fastslam]``, ``[corners]`` and ``[odometry]`` settings.

    With ``[scan_matching] enabled`` the filter moves by the log's laser odometry: ``laser`` if
    given (it does not depend on the filter's seed, so runs over several seeds can share it), else
    matched here; without it, ``laser`` is not used."""
    course_log = run.log
    if config.scan_matching.enabled and not course_log.scans_only:
        raise ValueError(
            f"{run.path}: [scan_matching] needs a log of scans (laser odometry moves the filter scan to "
            "scan); this one has landmark records or no scans: turn it off"
        )
    if not config.scan_matching.enabled:
        laser = None
    elif laser is None:
        laser = laser_odometry(course_log, run.geometry, config.scan_matching)
    identify = None
    if config.fastslam.association == Association.KNOWN and course_log.is_scan.any():
        identify = truth_identities(run, config.evaluation.match_radius)
    return run_fastslam(
        course_log,
        config.fastslam,
        config.corners,
        run.geometry,
        run.start_pose,
        progress,
        snapshot_every,
        config.odometry.jump_tolerance,
        identify,
        laser,
        on_update,
    )
