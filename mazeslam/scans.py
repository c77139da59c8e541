"""Scans of any log a user points mazeslam at, with the beam geometry that gives them bearings.

A course log carries no beam geometry: it comes from the log's map sidecar when there is one,
else from the caller (command line, config), else the exercise's convention is assumed and the
caller is told so. A CARMEN log's front laser has a known geometry.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mazeslam import log, sidecars
from mazeslam.beams import EXERCISE_CONVENTION, BeamGeometry
from mazeslam.imports.carmen import front_laser, is_carmen, read_carmen


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
    """

    source: str
    times: np.ndarray
    records: np.ndarray
    ranges: np.ndarray
    geometry: BeamGeometry
    geometry_origin: str
    true_poses: np.ndarray | None = None
    true_corners: np.ndarray | None = None

    @property
    def n_beams(self) -> int:
        return self.ranges.shape[1]


def resolve_geometry(path: str | Path, geometry_overrides: dict | None = None) -> tuple[BeamGeometry, str]:
    """The beam geometry of a course log, and where it came from: the map sidecar, else the
    exercise's convention; ``geometry_overrides`` (keys of ``BeamGeometry``) replace parts of it."""
    map_file = sidecars.map_path(path)
    if map_file.exists():
        geometry, origin = sidecars.beam_geometry(sidecars.read_map(map_file)["sensor"]), f"sidecar {map_file}"
    else:
        geometry, origin = EXERCISE_CONVENTION, "assumed: the exercise's convention (no sidecar)"
    return _override(geometry, origin, geometry_overrides)


def _override(geometry: BeamGeometry, origin: str, overrides: dict | None) -> tuple[BeamGeometry, str]:
    overrides = {k: v for k, v in (overrides or {}).items() if v is not None}
    if not overrides:
        return geometry, origin
    return dataclasses.replace(geometry, **overrides), f"{origin}, overridden by {', '.join(sorted(overrides))}"


def load_scans(path: str | Path, geometry_overrides: dict | None = None, strict: bool = True) -> ScanSet:
    """The scans of a course log or a CARMEN log (plain or gzipped).

    ``geometry_overrides`` (keys of ``BeamGeometry``: ``first_beam_angle``, ``direction``,
    ``mount_x``, ...) replace what the sidecar or the format says.
    """
    path = Path(path)
    true_poses = true_corners = None
    if is_carmen(path):
        carmen = read_carmen(path)
        geometry, origin = front_laser(carmen.n_beams), "CARMEN front laser"
        times, ranges = carmen.scan_times, carmen.ranges
        records = np.arange(len(times))
    else:
        course_log = log.read(path, strict=strict)
        if course_log.n_beams is None:
            raise ValueError(f"{path}: the log has no scan records")
        map_file, truth_file = sidecars.map_path(path), sidecars.truth_path(path)
        records = np.flatnonzero(course_log.is_scan)
        geometry, origin = resolve_geometry(path)
        if map_file.exists():
            true_corners = sidecars.read_map(map_file)["corners"]
        if truth_file.exists():
            true_poses = sidecars.read_truth(truth_file)[1][records]
        times, ranges = course_log.times[records], course_log.values[records]
    geometry, origin = _override(geometry, origin, geometry_overrides)
    return ScanSet(str(path), times, records, ranges, geometry, origin, true_poses, true_corners)
