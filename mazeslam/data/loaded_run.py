"""A loaded run: one log and everything beside it, read once and passed on.

The filter, the reports, the sweeps and the figures all need the same facts about a log: its
records, the beam geometry its scans were taken with, where the robot started, and - for simulated
or referenced logs - the truth and the world's map. ``load_run`` reads them once; nothing
downstream opens a sidecar again.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mazeslam.core.beams import EXERCISE_CONVENTION, BeamGeometry, SensorOverrides
from mazeslam.data import log, sidecars
from mazeslam.data.log import CourseLog


@dataclass(frozen=True)
class LoadedRun:
    """One log with its sidecars.

    Attributes:
        path: the log file.
        log: its records.
        geometry: the beam geometry of its scans; geometry_origin says where it came from (the
            map sidecar, the exercise's convention assumed, overrides), for messages.
        start_pose: (3,) world pose the robot started at (the map sidecar's, else the origin).
        truth: (R, 3) the true (or reference) pose at every record, or None without a truth sidecar.
        world: the map sidecar (walls (W, 4), corners (K, 2), sensor, ...), or None.
    """

    path: Path
    log: CourseLog
    geometry: BeamGeometry
    geometry_origin: str
    start_pose: np.ndarray
    truth: np.ndarray | None = None
    world: dict | None = None

    @property
    def name(self) -> str:
        """The log's file name without its extension (``runs/demo.log`` -> ``demo``)."""
        return self.path.stem

    @property
    def geometry_from_sidecar(self) -> bool:
        """The beam geometry was recorded beside the log (not assumed)."""
        return self.geometry_origin.startswith("sidecar")

    @property
    def true_corners(self) -> np.ndarray:
        """(K, 2) the world's true corners (empty without a map sidecar), metres."""
        return self.world["corners"] if self.world is not None else np.empty((0, 2))

    @property
    def walls(self) -> np.ndarray | None:
        """(W, 4) wall segments x1, y1, x2, y2 of the map sidecar, metres, or None."""
        return self.world["walls"] if self.world is not None else None

    @property
    def sensor_max_range(self) -> float:
        """The sensor's maximum range from the map sidecar (m; a beam with no return saw nothing
        nearer, ``sidecars.read_map`` checks it), or 0 when it is not recorded."""
        return float(((self.world or {}).get("sensor") or {}).get("max_range") or 0.0)

    @property
    def truth_label(self) -> str:
        """How figures and tables name the truth: a reference (CARMEN's corrected poses) is not truth."""
        return (self.world or {}).get("truth_kind", "ground truth")

    @property
    def truth_is_reference(self) -> bool:
        return self.truth_label.startswith("reference")

    @property
    def truth_path_label(self) -> str:
        """How a figure's legend names the truth's path: "reference path" or "true path"."""
        return "reference path" if self.truth_is_reference else "true path"

    def glitches(self, jump_tolerance: float) -> np.ndarray:
        """Record indices (G,) of the odometry records travelling more than ``jump_tolerance``
        metres in one step (the exercise's TOL_JMP): glitches, left out of the motion."""
        distance = np.abs(self.log.increments[:, 0])
        return np.flatnonzero(self.log.is_odometry & (distance > jump_tolerance))

    def glitch_pairs(self, jump_tolerance: float) -> list[tuple[int, int]]:
        """The glitches (``glitches``) that come in pairs: two consecutive odometry records whose
        summed motion is within ``jump_tolerance``, as record indices (first, second). The course
        robot's wheel counters wrap and unwrap one record later, so such a pair's sum is the real
        motion (log1's lines 79-80 and 196-197), while a lone jump is not motion."""
        glitches = set(self.glitches(jump_tolerance).tolist())
        odometry = np.flatnonzero(self.log.is_odometry)
        pairs: list[tuple[int, int]] = []
        for first, second in zip(odometry[:-1].tolist(), odometry[1:].tolist()):
            paired = pairs and pairs[-1][1] == first
            summed = self.log.values[first, 0] + self.log.values[second, 0]
            if first in glitches and second in glitches and not paired and abs(summed) <= jump_tolerance:
                pairs.append((first, second))
        return pairs

    def glitch_line(self, jump_tolerance: float, pairs_summed: bool = False) -> str | None:
        """A line listing the glitches (``glitches``) by log line, time and motion, and what the
        filter does with them: all left out, or (``pairs_summed``) each pair's sum kept and the lone
        ones left out; None without any."""
        glitches = self.glitches(jump_tolerance)
        if not len(glitches):
            return None
        lines = self.log.line_numbers if self.log.line_numbers is not None else glitches + 1
        described = {
            index: f"line {lines[index]} (t {self.log.times[index]:.3f} s, dX {self.log.increments[index, 0]:+.4f} m, "
            f"dTheta {self.log.increments[index, 1]:+.4f} rad)"
            for index in glitches
        }
        head = f"odometry records travelling more than {jump_tolerance:g} m in one step (glitches)"
        if not pairs_summed:
            return f"left out {len(glitches)} {head}: " + ", ".join(described.values())
        pairs = self.glitch_pairs(jump_tolerance)
        lone = sorted(set(glitches.tolist()) - {index for pair in pairs for index in pair})
        parts = [f"{described[a]} + {described[b]} summed (a pair: its sum is the motion)" for a, b in pairs]
        parts += [f"{described[index]} left out" for index in lone]
        return f"{len(glitches)} {head}: " + "; ".join(parts)

    def log_with_glitch_pairs_summed(self, jump_tolerance: float) -> CourseLog:
        """The log with each glitch pair (``glitch_pairs``) replaced by its sum on its second
        record and every other glitch set to no motion."""
        values = self.log.values.copy()
        pairs = self.glitch_pairs(jump_tolerance)
        for first, second in pairs:
            values[second, :2] += values[first, :2]
            values[first, :2] = 0.0
        paired = {index for pair in pairs for index in pair}
        values[[index for index in self.glitches(jump_tolerance).tolist() if index not in paired], :2] = 0.0
        return dataclasses.replace(self.log, values=values)

    def log_without_glitches(self, jump_tolerance: float) -> CourseLog:
        """The log with the glitches' odometry (``glitches``) set to no motion, as the filter moves."""
        return self.log_without(self.glitches(jump_tolerance))

    def log_without(self, records) -> CourseLog:
        """The log with the odometry of ``records`` (indices) set to no motion."""
        return self.log.without_motion(records)


def load_run(path: str | Path, sensor: SensorOverrides | None = None, strict: bool = True) -> LoadedRun:
    """Read a course log and its sidecars (``run.truth.csv``, ``run.map.json``) once.

    The beam geometry comes from the map sidecar, else the exercise's convention is assumed;
    ``sensor`` replaces the parts it gives. ``strict=False`` skips bad log lines (reported in
    ``log.skipped``) instead of stopping.
    """
    path = Path(path)
    course_log = log.read(path, strict=strict)
    map_file, truth_file = sidecars.map_path(path), sidecars.truth_path(path)
    world = sidecars.read_map(map_file) if map_file.exists() else None
    truth = sidecars.read_truth(truth_file)[1] if truth_file.exists() else None
    if truth is not None and len(truth) == len(course_log) + 1 and not course_log.skipped:
        truth = truth[:-1]  # a recording killed between a record's true pose and its log line
    if truth is not None and len(truth) != len(course_log):
        raise ValueError(f"{truth_file}: {len(truth)} poses for the {len(course_log)} records of {path}")
    if world is not None:
        geometry, origin = sidecars.beam_geometry(world["sensor"]), f"sidecar {map_file}"
    else:
        geometry, origin = EXERCISE_CONVENTION, "assumed: the exercise's convention (no sidecar)"
    geometry, origin = (sensor or SensorOverrides()).apply_described(geometry, origin)
    start = (world or {}).get("start_pose")
    start_pose = np.asarray(start if start is not None else (0.0, 0.0, 0.0), dtype=float)
    return LoadedRun(path, course_log, geometry, origin, start_pose, truth, world)
