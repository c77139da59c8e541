"""Which settings fit a log, when none are given: its kind, told by its sidecar or its scans.

Every log the project writes or imports says where it came from in its map sidecar
(``mazeslam simulate``, ``mazeslam import carmen|mrclam``, ``mazeslam record``, the Gymnasium
recorder); the exercise robot's own logs come without one but with 360 camera ranges of at most
about 1.8 m. ``chosen_config`` names the file under ``configs/`` that fits (``SETTINGS``), loads it
and says so in one line; ``mazeslam slam`` and ``slam_on_file`` use it when no config is given.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass
from pathlib import Path

from mazeslam.core.config import InputError
from mazeslam.data.loaded_run import LoadedRun, load_run
from mazeslam.pipeline.config import SlamConfig, load_slam_config

#: The project's configs/ folder (beside the package in a clone or an editable install).
CONFIGS_FOLDER = Path(__file__).resolve().parents[2] / "configs"
#: The exercise robot's camera: 360 ranges a scan, none beyond the mirror's ring (1.78 m).
COURSE_ROBOT_BEAMS = 360
COURSE_ROBOT_MAX_RANGE = 2.0  # m
#: The map sidecar's ``source`` of a real-robot recording (``mazeslam.robot.recorder``).
REAL_ROBOT_SOURCE = "mazeslam record (real robot"
#: The map sidecar's ``source`` of a simulated building (``mazeslam.sim.building``).
BUILDING_SOURCE = "mazeslam.sim.building"


class LogKind(enum.Enum):
    """What made a log, as far as its sidecar and scans tell; the value says it in words."""

    MAZE_SIMULATION = "a simulated maze (its sidecar's laser is the default one)"
    COURSE_SIMULATION = "a simulated course robot (its sidecar's laser is the omnidirectional camera)"
    BUILDING_SIMULATION = "a simulated building of corridors and a SICK-like laser (mazeslam.sim.building)"
    COURSE_ROBOT = "the exercise robot's own log (no sidecar; 360 camera ranges of at most 2 m)"
    REAL_ROBOT = "a recording of the real e-puck (`mazeslam record`)"
    CARMEN = "a CARMEN log imported by `mazeslam import carmen`"
    CARMEN_WITHOUT_ODOMETRY = "a CARMEN log without odometry records, imported by `mazeslam import carmen`"
    MRCLAM = "an MRCLAM log imported by `mazeslam import mrclam`"
    UNKNOWN = "of no kind its sidecar or scans tell"


#: The config file under configs/ that fits each kind; None: the defaults (written out in
#: configs/fastslam.toml), which are measured on simulated mazes.
SETTINGS: dict[LogKind, str | None] = {
    LogKind.MAZE_SIMULATION: None,
    LogKind.COURSE_SIMULATION: "course.toml",
    LogKind.BUILDING_SIMULATION: "carmen.toml",
    LogKind.COURSE_ROBOT: "course.toml",
    LogKind.REAL_ROBOT: "course.toml",
    LogKind.CARMEN: "carmen.toml",
    LogKind.CARMEN_WITHOUT_ODOMETRY: "carmen_without_odometry.toml",
    LogKind.MRCLAM: "mrclam.toml",
    LogKind.UNKNOWN: None,
}


def log_kind(run: LoadedRun) -> LogKind:
    """The kind of the loaded log ``run``: from its map sidecar's ``source`` and sensor when it has
    one, else from its scans (the exercise robot's camera gives 360 ranges of at most 2 m)."""
    if run.world is None:
        return LogKind.COURSE_ROBOT if _course_robot_scans(run) else LogKind.UNKNOWN
    source = run.world.get("source")
    if isinstance(source, dict) and "carmen_log" in source:
        return LogKind.CARMEN if run.log.is_odometry.any() else LogKind.CARMEN_WITHOUT_ODOMETRY
    if isinstance(source, dict) and "dataset" in source and run.log.is_landmark.any():
        return LogKind.MRCLAM
    if isinstance(source, str) and source.startswith(REAL_ROBOT_SOURCE):
        return LogKind.REAL_ROBOT
    if isinstance(source, str) and source.startswith(BUILDING_SOURCE):
        return LogKind.BUILDING_SIMULATION
    if (run.world.get("sensor") or {}).get("model") == "omnicam":
        return LogKind.COURSE_SIMULATION
    if len(run.world["walls"]) and run.log.is_scan.any():
        return LogKind.MAZE_SIMULATION
    return LogKind.UNKNOWN


def _course_robot_scans(run: LoadedRun) -> bool:
    """The log's scans look like the exercise robot's camera: 360 beams, no range beyond 2 m."""
    scans = run.log.scans
    return run.log.n_beams == COURSE_ROBOT_BEAMS and bool(scans.max(initial=0.0) <= COURSE_ROBOT_MAX_RANGE)


@dataclass(frozen=True)
class ConfigChoice:
    """The settings chosen for a log given without a config: ``config`` loaded from ``configs/``
    ``file`` (None: the defaults), and ``line``, one line saying which and why."""

    kind: LogKind
    file: str | None
    config: SlamConfig
    line: str


def chosen_config(path: str | Path, folder: Path = CONFIGS_FOLDER) -> ConfigChoice:
    """The settings that fit the log file ``path`` (``log_kind`` of its sidecars and scans, ``SETTINGS``),
    read from ``folder``; an ``InputError`` naming the file to give with --config when it is not there
    (an installation without the project's configs/ folder)."""
    run = load_run(path)
    kind = log_kind(run)
    name = SETTINGS[kind]
    if name is None:
        defaults = "the defaults (configs/fastslam.toml, measured on simulated mazes)"
        if kind is LogKind.UNKNOWN:
            line = (
                f"settings: {defaults}, as {run.path.name} is {kind.value}; --config names others "
                "(configs/course.toml: the exercise's robot, configs/carmen.toml, configs/mrclam.toml: imports)"
            )
        else:
            line = f"settings: {defaults}, as {run.path.name} is {kind.value}; --config overrides"
        return ConfigChoice(kind, None, SlamConfig(), line)
    file = folder / name
    if not file.is_file():
        raise InputError(
            f"{run.path}: {kind.value}, which wants --config configs/{name} (not found at {file}: give its path)"
        )
    line = f"settings: configs/{name}, as {run.path.name} is {kind.value}; --config overrides"
    return ConfigChoice(kind, name, load_slam_config(file), line)


def settings_for(path: str | Path, config_path: str | Path | None) -> tuple[SlamConfig, str | None]:
    """The settings of a run on the log ``path``: the config file ``config_path`` when given (and no
    line), else the one that fits the log's kind (``chosen_config``) and the line that says which."""
    if config_path is not None:
        return load_slam_config(config_path), None
    choice = chosen_config(path)
    return choice.config, choice.line
