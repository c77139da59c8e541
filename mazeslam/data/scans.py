"""Scans of any log a user points mazeslam at, with the beam geometry that gives them bearings.

A course log carries no beam geometry: it comes from the log's map sidecar when there is one,
else from the caller (command line, config), else the exercise's convention is assumed and the
caller is told so. A CARMEN log's front laser has a known geometry.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mazeslam.core.beams import BeamGeometry, SensorOverrides
from mazeslam.core.geometry import transform_points
from mazeslam.data import log
from mazeslam.data.carmen import front_laser, is_carmen, read_carmen
from mazeslam.data.loaded_run import LoadedRun, load_run


@dataclass
class ScanSet:
    """The scans of one log.

    Attributes:
        source: the file.
        times: (S,) seconds; records: (S,) record numbers in the log (the line order of scans).
        ranges: (S, N) metres, 0 = no return.
        geometry: beam geometry of the scans; geometry_origin: where it came from (for messages).
        true_poses: (S, 3) the true robot pose at each scan, when a truth sidecar exists.
        true_corners: (K, 2) the world's true corners, when a map sidecar exists.
        run: the loaded course log the scans come from (None for a CARMEN log).
    """

    source: str
    times: np.ndarray
    records: np.ndarray
    ranges: np.ndarray
    geometry: BeamGeometry
    geometry_origin: str
    true_poses: np.ndarray | None = None
    true_corners: np.ndarray | None = None
    run: LoadedRun | None = None

    @property
    def n_beams(self) -> int:
        return self.ranges.shape[1]


def load_scans(path: str | Path, sensor: SensorOverrides | None = None, strict: bool = True) -> ScanSet:
    """The scans of a course log or a CARMEN log (plain or gzipped); ``sensor`` replaces parts of
    the beam geometry the sidecar or the format gives."""
    path = Path(path)
    sensor = sensor or SensorOverrides()
    if is_carmen(path):
        carmen = read_carmen(path)
        geometry, origin = sensor.apply_described(front_laser(carmen.n_beams), "CARMEN front laser")
        return ScanSet(str(path), carmen.scan_times, np.arange(len(carmen.scan_times)), carmen.ranges, geometry, origin)
    run = load_run(path, sensor, strict=strict)
    if run.log.n_beams is None:
        raise ValueError(f"{path}: the log has no scan records")
    records = np.flatnonzero(run.log.is_scan)
    return ScanSet(
        str(path),
        run.log.times[records],
        records,
        run.log.values[records],
        run.geometry,
        run.geometry_origin,
        None if run.truth is None else run.truth[records],
        None if run.world is None else run.true_corners,
        run,
    )


def scan_points_world(
    course_log: log.CourseLog,
    poses: np.ndarray,
    geometry: BeamGeometry,
    min_range: float = 0.0,
    max_range: float = np.inf,
) -> np.ndarray:
    """Every scan's returns within [min_range, max_range] (Q, 2), placed in the world by the
    given poses (R, 3) of the records."""
    chunks = [
        transform_points(poses[index], geometry.returns(course_log.values[index], min_range, max_range))
        for index in np.flatnonzero(course_log.is_scan)
    ]
    return np.concatenate(chunks) if chunks else np.empty((0, 2))
