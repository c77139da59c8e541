"""``SlamResult``: what a SLAM run over a log gives, whichever filter ran (``run_slam``)."""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING, Any

import numpy as np

from mazeslam.evaluation.consistency import OBSERVATION_BOUND_95, POSE_BOUND_95, summarise
from mazeslam.pipeline.config import MapKind

if TYPE_CHECKING:
    from mazeslam.data.map_io import OccupancyMap
    from mazeslam.fastslam.filter import UpdateReport
    from mazeslam.gridslam.filter import GridSlamResult
    from mazeslam.gridslam.occupancy import TiledGrid
    from mazeslam.registration.scan_matching import LaserOdometry


@dataclass(kw_only=True)
class SlamResult:
    """A filter run over a log: poses at every record, the best particle's map, the filter's reports.

    World frame, metres and radians; R records, S of them with an estimate of their own.

    Attributes:
        kind: the map the particles built (``MapKind``): landmarks (corner FastSLAM) or a grid.
        times: (R,) the log's record times, s.
        mean_poses: (R, 3) the particle cloud's weighted mean after each record.
        best_poses: (R, 3) the most probable particle's pose after each record (corner FastSLAM: the
            particle most probable at that record; the grid filter: the final best particle's path).
        pose_covariances: (R, 3, 3) the cloud's covariance after each record.
        estimated_records: (S,) the records the filter estimated a pose at: every record, or only
            the scans when it moves by laser odometry or maps a grid (a record between two scans
            then holds the last scan's pose moved on by the odometry); what a run is scored at.
        dead_reckoning: (R, 3) the odometry's own path from the start pose, with the glitches the
            filter left out left out too.
        step_seconds: (R,) wall-clock seconds each record took.
        landmarks: (L, 2) and landmark_covariances (L, 2, 2): the best particle's landmarks
            (none for a grid).
        grid: the best particle's occupancy grid (None for landmarks).
        nis: (A,) the normalised innovation squared the filter checks itself by, with
            ``nis_dof`` degrees of freedom: corner FastSLAM's associated observations (2), the
            grid filter's scan-match corrections of the motion (3).
        reports: corner FastSLAM's ``UpdateReport`` per observation update (empty for a grid).
        observation_kinds: per report, the kind of each of its observations (``corner``,
            ``wall_end``, ...; ``landmark`` for landmark records).
        updates: observation updates (scans or landmark groups) the filter made.
        resamplings: how many times the filter resampled.
        snapshots: the frames kept for an animation (see the filter's runner).
        filter: the final filter (``FastSLAM`` or ``GridSlam``), for inspection.
        dropped_odometry: the odometry records left out as glitches (``OdometryRecord``s).
        laser_odometry: the scan-to-scan motion corner FastSLAM moved by, when it did.
        grid_run: the grid filter's own per-scan record (``GridSlamResult``), None for landmarks.
    """

    kind: MapKind
    times: np.ndarray
    mean_poses: np.ndarray
    best_poses: np.ndarray
    pose_covariances: np.ndarray
    estimated_records: np.ndarray
    dead_reckoning: np.ndarray
    step_seconds: np.ndarray
    landmarks: np.ndarray = field(default_factory=lambda: np.empty((0, 2)))
    landmark_covariances: np.ndarray = field(default_factory=lambda: np.empty((0, 2, 2)))
    grid: TiledGrid | None = None
    nis: np.ndarray = field(default_factory=lambda: np.empty(0))
    nis_dof: int = 2
    reports: list[UpdateReport] = field(default_factory=list)
    observation_kinds: list[list[str]] = field(default_factory=list)
    updates: int = 0
    resamplings: int = 0
    snapshots: list = field(default_factory=list)
    filter: Any = None
    dropped_odometry: list = field(default_factory=list)
    laser_odometry: LaserOdometry | None = None
    grid_run: GridSlamResult | None = None

    @cached_property
    def occupancy(self) -> OccupancyMap | None:
        """The cell states of ``grid`` (``grid_states``: occupied, free, unknown), None without a
        grid; worked out once for the files and figures that show it."""
        if self.grid is None:
            return None
        from mazeslam.gridslam.occupancy import grid_states

        return grid_states(self.grid)

    @property
    def filter_name(self) -> str:
        """ "FastSLAM" or "grid filter", as tables and titles name the filter."""
        return self.kind.filter_name

    def nis_by_kind(self) -> dict[str, np.ndarray]:
        """The run's NIS values (``nis``) grouped by the kind of observation they belong to: which
        part of the observation model is too wide (NIS well under its dof) or too narrow (well over).
        The grid filter's are all ``"motion"``."""
        if self.kind == MapKind.GRID:
            return {"motion": self.nis} if len(self.nis) else {}
        groups: dict[str, list[float]] = {}
        for report, kinds in zip(self.reports, self.observation_kinds):
            for value, index in zip(report.nis, report.nis_observations):
                groups.setdefault(kinds[index], []).append(float(value))
        return {kind: np.asarray(values) for kind, values in groups.items()}

    @property
    def nis_bound(self) -> float:
        """The chi-square 95 % point of ``nis`` (``nis_dof`` degrees of freedom)."""
        return OBSERVATION_BOUND_95 if self.nis_dof == 2 else POSE_BOUND_95

    def nis_summary(self) -> dict:
        """``nis`` summarised (``consistency.summarise``) against ``nis_bound``."""
        return summarise(self.nis, self.nis_bound)

    @property
    def resampled_fraction(self) -> float:
        """Share of the observation updates after which the filter resampled (0 without any)."""
        return self.resamplings / self.updates if self.updates else 0.0
