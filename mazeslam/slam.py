"""Run FastSLAM over a whole log: odometry records predict, scan records extract corners and update.

This is the exercise's main loop (fastslam1_sim.m): for every line of the log, an odometry entry
moves the particles, a laser entry is turned into corner observations that weigh and correct them.
With laser odometry (``[scan_matching] enabled``), the particles move at each scan by the scan's
match to the one before instead, and odometry records only inform that match.
"""

from __future__ import annotations

import enum
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mazeslam import log
from mazeslam.beams import EXERCISE_CONVENTION, BeamGeometry, SensorOverrides
from mazeslam.config import load_toml
from mazeslam.filters.association import nearest_within
from mazeslam.filters.corners import CornerExtractor, CornerParams
from mazeslam.filters.fastslam import Association, FastSLAM, FastSLAMParams, UpdateReport
from mazeslam.filters.scan_matching import LaserOdometry, ScanMatchParams, laser_odometry
from mazeslam.geometry import polar_to_cartesian, transform_points
from mazeslam.grid.filter import GridSlamParams
from mazeslam.loaded_run import LoadedRun, load_run


@dataclass
class SlamResult:
    """A filter run over a log.

    Attributes:
        times: (R,) the log's record times, s.
        mean_poses: (R, 3) weighted-mean pose after each record (world frame).
        best_poses: (R, 3) pose of the most probable particle after each record.
        landmarks: (L, 2) and landmark_covariances (L, 2, 2): the best particle's final map.
        step_seconds: (R,) wall-clock seconds each record took.
        reports: one ``UpdateReport`` per scan.
        resamplings: how many times the filter resampled.
        filter: the final filter (particles, weights, maps) for inspection.
        snapshots: every ``snapshot_every``-th scan: (record index, particle poses (P, 3), best
            particle's landmarks (L, 2)), for animations.
        dropped_odometry: the odometry records left out as glitches (``OdometryRecord``s).
        pose_covariances: (R, 3, 3) the particle cloud's covariance after each record.
        laser_odometry: the scan-to-scan motion the filter moved by, when it used laser odometry
            (records between scans then keep the previous scan's pose).
        observation_kinds: per report, the kind of each of its observations (the corner
            extractor's ``corner``, ``wall_end``, ...; ``landmark`` for landmark records).
    """

    times: np.ndarray
    mean_poses: np.ndarray
    best_poses: np.ndarray
    landmarks: np.ndarray
    landmark_covariances: np.ndarray
    step_seconds: np.ndarray
    filter: FastSLAM
    pose_covariances: np.ndarray
    reports: list[UpdateReport] = field(default_factory=list)
    resamplings: int = 0
    snapshots: list = field(default_factory=list)
    dropped_odometry: list = field(default_factory=list)
    laser_odometry: LaserOdometry | None = None
    observation_kinds: list[list[str]] = field(default_factory=list)

    @property
    def nis(self) -> np.ndarray:
        """(A,) the normalised innovation squared of every associated observation of the run."""
        return np.concatenate([report.nis for report in self.reports]) if self.reports else np.empty(0)

    def nis_by_kind(self) -> dict[str, np.ndarray]:
        """The run's NIS values (``nis``) grouped by the kind of observation they belong to: which
        part of the observation model is too wide (NIS well under 2) or too narrow (well over)."""
        groups: dict[str, list[float]] = {}
        for report, kinds in zip(self.reports, self.observation_kinds):
            for value, index in zip(report.nis, report.nis_observations):
                groups.setdefault(kinds[index], []).append(float(value))
        return {kind: np.asarray(values) for kind, values in groups.items()}

    @property
    def resampled_fraction(self) -> float:
        """Share of the observation updates after which the filter resampled (0 without any)."""
        return self.resamplings / len(self.reports) if self.reports else 0.0


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
    a live view: ``mazeslam.live``); it must not change the filter.
    """
    params = params or FastSLAMParams()
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
            reports.append(
                slam.update(z, covariances, ids if params.association == Association.KNOWN else None, facings)
            )
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
        course_log.times,
        mean_poses,
        best_poses,
        landmarks,
        covariances,
        step_seconds,
        filter=slam,
        pose_covariances=pose_covariances,
        reports=reports,
        resamplings=slam.resamplings,
        snapshots=snapshots,
        dropped_odometry=dropped,
        laser_odometry=laser,
        observation_kinds=observation_kinds,
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


def slam_on_run(
    run: LoadedRun,
    config: SlamConfig | None = None,
    progress: bool = True,
    snapshot_every: int = 0,
    laser: LaserOdometry | None = None,
    on_update=None,
) -> SlamResult:
    """``run_fastslam`` on a loaded log, from its start pose with its beam geometry.

    With ``[scan_matching] enabled`` the filter moves by the log's laser odometry: ``laser`` if
    given (it does not depend on the filter's seed, so runs over several seeds can share it), else
    matched here; without it, ``laser`` is not used."""
    config = config or SlamConfig()
    course_log = run.log
    if config.scan_matching.enabled and (not course_log.is_scan.any() or course_log.is_landmark.any()):
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


def slam_on_file(
    path: str | Path,
    config: SlamConfig | None = None,
    progress: bool = True,
    snapshot_every: int = 0,
    laser: LaserOdometry | None = None,
) -> SlamResult:
    """``slam_on_run`` on a log file (its sidecars read beside it, ``[sensor]`` applied)."""
    config = config or SlamConfig()
    return slam_on_run(load_run(path, config.sensor), config, progress, snapshot_every, laser)


def truth_identities(run: LoadedRun, radius: float):
    """For known association on a simulated log: name each observation by the true corner (map
    sidecar) within ``radius`` metres of where the true pose (truth sidecar) puts it; -1 if none.
    A diagnosis tool: it tells association errors apart from everything else."""
    if run.truth is None or run.world is None:
        raise ValueError(f"{run.path}: known association on scans needs the truth and map sidecars to name the corners")
    return identities_along(run.truth, run.true_corners, radius)


def identities_along(poses: np.ndarray, landmarks: np.ndarray, radius: float):
    """``identify(record_index, observations (K, 2)) -> ids (K,)``: each observation named by the
    landmark (L, 2) nearest to where the pose of its record (``poses`` (R, 3)) puts it, within
    ``radius`` metres; -1 if none (``association.nearest_within``)."""

    def identify(record_index: int, observations: np.ndarray) -> np.ndarray:
        world = transform_points(poses[record_index], polar_to_cartesian(observations[:, 0], observations[:, 1]))
        return nearest_within(world, landmarks, radius)

    return identify


@dataclass(frozen=True)
class OdometryCleaning:
    """Odometry records to leave out: a record reporting more than ``jump_tolerance`` metres in one
    step is a glitch (the exercise's TOL_JMP); every one left out is reported."""

    jump_tolerance: float = math.inf

    def __post_init__(self):
        if not self.jump_tolerance > 0:
            raise ValueError(f"jump_tolerance must be positive, got {self.jump_tolerance}")


@dataclass(frozen=True)
class EvaluationParams:
    """How a run is scored against truth: an estimated landmark counts as a true one's within
    ``match_radius`` metres."""

    match_radius: float = 0.05

    def __post_init__(self):
        if not 0 < self.match_radius <= 100:
            raise ValueError(f"match_radius must be in (0, 100] m, got {self.match_radius}")


class MapKind(enum.StrEnum):
    """What the particles map."""

    LANDMARKS = "landmarks"  #: corners (and wall ends) with an EKF each: FastSLAM, ``[fastslam]``
    GRID = "grid"  #: an occupancy grid each, matched against: gmapping's filter, ``[grid]``


@dataclass(frozen=True)
class MapParams:
    """``[map]``: which map the particle filter builds."""

    kind: MapKind = MapKind.LANDMARKS

    def __post_init__(self):
        object.__setattr__(self, "kind", MapKind(self.kind))


@dataclass(frozen=True)
class SlamConfig:
    """Everything ``mazeslam slam`` needs; TOML sections ``[map]``, ``[fastslam]`` or ``[grid]``,
    ``[corners]`` (with ``[corners.lines]``), ``[sensor]``, ``[odometry]``, ``[scan_matching]`` and
    ``[evaluation]``. The grid filter moves by ``[scan_matching]``'s laser odometry when that is
    enabled."""

    map: MapParams = field(default_factory=MapParams)
    grid: GridSlamParams = field(default_factory=GridSlamParams)
    fastslam: FastSLAMParams = field(default_factory=FastSLAMParams)
    corners: CornerParams = field(default_factory=CornerParams)
    sensor: SensorOverrides = field(default_factory=SensorOverrides)
    odometry: OdometryCleaning = field(default_factory=OdometryCleaning)
    scan_matching: ScanMatchParams = field(default_factory=ScanMatchParams)
    evaluation: EvaluationParams = field(default_factory=EvaluationParams)


def load_slam_config(path: str | Path | None) -> SlamConfig:
    """A ``SlamConfig`` from TOML, or the defaults when ``path`` is None."""
    return SlamConfig() if path is None else load_toml(SlamConfig, path)
