"""Map sharpness: how smeared a log's walls are when its scans are placed along a path.

The measure for real logs without truth. Every scan's returns with range in
[``min_range``, ``max_range``] are placed at the estimated pose of their record (the log's beam
geometry and mounting offset) and the distinct occupied ``cell`` x ``cell`` cells are counted:
fewer cells mean sharper walls. Dead reckoning is the same count along the integrated odometry,
with the glitch records (more than ``jump_tolerance`` metres in one step, the exercise's TOL_JMP)
left out as the filter leaves them out.

A path that shrinks also looks sharper, so the path's extent (the diagonal of its bounding box)
is reported beside the count: a fair comparison keeps it near dead reckoning's.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from mazeslam.core.beams import BeamGeometry
from mazeslam.core.motion import dead_reckoning
from mazeslam.data import log
from mazeslam.data.loaded_run import LoadedRun
from mazeslam.data.scans import scan_points_world

#: The measure's defaults: returns of 0.05-0.4 m (the course camera's trusted span), 1 cm cells.
TRUSTED_SPAN = (0.05, 0.4)
CELL = 0.01
#: A path whose bounding box is smaller than this (m) stands still.
STANDING_STILL = 1e-6


def occupied_cells(
    course_log: log.CourseLog,
    poses: np.ndarray,
    geometry: BeamGeometry,
    min_range: float = TRUSTED_SPAN[0],
    max_range: float = TRUSTED_SPAN[1],
    cell: float = CELL,
) -> int:
    """How many distinct ``cell``-sized squares (m) the scans' returns occupy when placed by
    ``poses`` (R, 3), one world pose per record of ``course_log``."""
    points = scan_points_world(course_log, poses, geometry, min_range, max_range)
    return len(np.unique(np.floor(points / cell).astype(np.int64), axis=0))


def path_extent(poses: np.ndarray) -> float:
    """The diagonal of the bounding box of the positions of ``poses`` (R, 3), metres."""
    if not len(poses):
        return 0.0
    span = poses[:, :2].max(axis=0) - poses[:, :2].min(axis=0)
    return float(math.hypot(*span))


@dataclass(frozen=True)
class Sharpness:
    """A path's map sharpness beside dead reckoning's.

    Attributes:
        cells, dead_reckoning_cells: occupied 1 cm cells along the path and along dead reckoning.
        extent_m, dead_reckoning_extent_m: the paths' bounding-box diagonals, metres.
    """

    cells: int
    dead_reckoning_cells: int
    extent_m: float
    dead_reckoning_extent_m: float

    @property
    def ratio(self) -> float:
        """cells / dead reckoning's cells: below 1 is sharper than the odometry."""
        return self.cells / max(self.dead_reckoning_cells, 1)

    @property
    def extent_ratio(self) -> float | None:
        """The path's extent over dead reckoning's (a shrunken path looks sharper: keep near 1);
        None where dead reckoning stands still (a log without odometry)."""
        if self.dead_reckoning_extent_m < STANDING_STILL:
            return None
        return self.extent_m / self.dead_reckoning_extent_m

    def to_dict(self) -> dict:
        return {**asdict(self), "ratio": self.ratio, "extent_ratio": self.extent_ratio}

    def describe(self, name: str) -> str:
        """A line for the terminal: the counts, their ratio and the extents' (without a dead
        reckoning that moves, the path's own count and extent in metres)."""
        if self.extent_ratio is None:
            return (
                f"  {name}: {self.cells} occupied 1 cm cells, path extent {self.extent_m:.2f} m (dead reckoning "
                "stands still, as on a log without odometry: nothing to compare with)"
            )
        return (
            f"  {name}: {self.cells} occupied 1 cm cells against dead reckoning's {self.dead_reckoning_cells} "
            f"(x{self.ratio:.2f}; fewer = sharper walls), path extent x{self.extent_ratio:.2f} of dead reckoning's"
        )


def dead_reckoning_without_glitches(run: LoadedRun, jump_tolerance: float) -> np.ndarray:
    """(R, 3) the odometry integrated from the run's start, the glitch records left out."""
    return dead_reckoning(run.log_without_glitches(jump_tolerance), run.start_pose)


def paths_sharpness(
    run: LoadedRun,
    paths: dict[str, np.ndarray],
    jump_tolerance: float = math.inf,
    min_range: float = TRUSTED_SPAN[0],
    max_range: float = TRUSTED_SPAN[1],
) -> dict[str, Sharpness]:
    """Sharpness of ``run``'s scans placed by each of ``paths`` (name -> (R, 3) poses), each
    beside dead reckoning (placed and counted once)."""
    reckoned = dead_reckoning_without_glitches(run, jump_tolerance)
    reckoned_cells = occupied_cells(run.log, reckoned, run.geometry, min_range, max_range)
    return {
        name: Sharpness(
            occupied_cells(run.log, poses, run.geometry, min_range, max_range),
            reckoned_cells,
            path_extent(poses),
            path_extent(reckoned),
        )
        for name, poses in paths.items()
    }


def map_sharpness(
    run: LoadedRun,
    poses: np.ndarray,
    jump_tolerance: float = math.inf,
    min_range: float = TRUSTED_SPAN[0],
    max_range: float = TRUSTED_SPAN[1],
) -> Sharpness:
    """Sharpness of ``run``'s scans placed by ``poses`` (R, 3) and by dead reckoning."""
    return paths_sharpness(run, {"path": poses}, jump_tolerance, min_range, max_range)["path"]


def sharpness_lines(sharpness: dict[str, Sharpness], min_range: float, max_range: float) -> list[str]:
    """Lines for the terminal: a heading, then per path the counts, their ratio and the extents'."""
    return [
        f"Map sharpness (scan returns {span_text(min_range, max_range)} placed along each path; dead reckoning "
        "leaves the glitches out):"
    ] + [value.describe(name) for name, value in sharpness.items()]


def span_text(min_range: float, max_range: float) -> str:
    """The ranges (m) of the returns used, in words: "of 0.05-0.4 m", or "from 0.02 m on" without an
    upper bound (an infinite ``max_range``: no "inf" printed)."""
    return f"of {min_range:g}-{max_range:g} m" if math.isfinite(max_range) else f"from {min_range:g} m on"
