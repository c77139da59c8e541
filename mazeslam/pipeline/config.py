"""``SlamConfig``: every setting of a SLAM run, from one TOML file.

Sections: ``[map]`` (which filter: corner landmarks or an occupancy grid), ``[fastslam]`` or
``[grid]`` (that filter's settings), ``[corners]`` (with ``[corners.lines]``), ``[sensor]``,
``[odometry]``, ``[scan_matching]``, ``[posegraph]`` (a laser log's optimum, ``mazeslam smooth``)
and ``[evaluation]``. ``mazeslam.pipeline.run_slam`` reads ``[map] kind`` and runs the filter it names.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, field, replace
from pathlib import Path

from mazeslam.core.beams import SensorOverrides
from mazeslam.core.config import load_toml
from mazeslam.fastslam.filter import FastSLAMParams
from mazeslam.features.corners import CornerParams
from mazeslam.gridslam.filter import GridSlamParams
from mazeslam.posegraph.params import PoseGraphParams
from mazeslam.registration.scan_matching import ScanMatchParams


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

    @property
    def filter_name(self) -> str:
        """The filter that builds this map, as outputs and tables name it."""
        return "FastSLAM" if self is MapKind.LANDMARKS else "grid filter"


@dataclass(frozen=True)
class MapParams:
    """``[map]``: which map the particle filter builds."""

    kind: MapKind = MapKind.LANDMARKS

    def __post_init__(self):
        object.__setattr__(self, "kind", MapKind(self.kind))


@dataclass(frozen=True)
class SlamConfig:
    """Everything ``mazeslam slam`` needs; TOML sections ``[map]``, ``[fastslam]`` or ``[grid]``,
    ``[corners]`` (with ``[corners.lines]``), ``[sensor]``, ``[odometry]``, ``[scan_matching]``,
    ``[posegraph]`` and ``[evaluation]``. The grid filter moves by ``[scan_matching]``'s laser odometry when that is
    enabled."""

    map: MapParams = field(default_factory=MapParams)
    grid: GridSlamParams = field(default_factory=GridSlamParams)
    fastslam: FastSLAMParams = field(default_factory=FastSLAMParams)
    corners: CornerParams = field(default_factory=CornerParams)
    sensor: SensorOverrides = field(default_factory=SensorOverrides)
    odometry: OdometryCleaning = field(default_factory=OdometryCleaning)
    scan_matching: ScanMatchParams = field(default_factory=ScanMatchParams)
    posegraph: PoseGraphParams = field(default_factory=PoseGraphParams)
    evaluation: EvaluationParams = field(default_factory=EvaluationParams)

    @property
    def particles(self) -> int:
        """The particle count of the filter ``[map] kind`` names."""
        return self.fastslam.NPARTICLES if self.map.kind == MapKind.LANDMARKS else self.grid.particles

    @property
    def grid_filter(self) -> GridSlamParams:
        """The grid filter's settings as it runs: ``[grid]``, moving by ``[scan_matching]``'s laser
        odometry when that is enabled."""
        if self.scan_matching.enabled:
            return replace(self.grid, laser_odometry=self.scan_matching)
        return self.grid

    def with_sensor(self, overrides: SensorOverrides | None) -> SlamConfig:
        """These settings with the ``[sensor]`` values ``overrides`` gives (command-line beam geometry)
        over the config's; None keeps them."""
        return self if overrides is None else replace(self, sensor=overrides.over(self.sensor))

    def with_seed(self, seed: int) -> SlamConfig:
        """These settings with both filters' random draws seeded by ``seed``."""
        return replace(self, fastslam=replace(self.fastslam, seed=seed), grid=replace(self.grid, seed=seed))


def load_slam_config(path: str | Path | None) -> SlamConfig:
    """A ``SlamConfig`` from TOML, or the defaults when ``path`` is None."""
    return SlamConfig() if path is None else load_toml(SlamConfig, path)
