"""The simulator: drive the e-puck through a maze and write a course log with truth and map sidecars.

``simulate`` runs the physics at ``physics_rate`` Hz. Like the exercise's logger (its Main.m), it
writes an odometry record every ``1 / odometry_rate`` s (F_O_U) and a scan every ``scan_period`` s
(T_b_S) with ``laser.beams`` beams (N). By default the logger also reads the encoders before every
scan, so an odometry record with the same timestamp precedes each scan: the scan is taken exactly
at the pose the odometry up to it describes. With ``odometry_with_scan = false`` it does not, as
the course robot's logger (log1 scans 0.26 s after its last odometry record): a filter that places
a scan at the last odometry pose then places it at a pose up to 1/F_O_U seconds old.

With ``odometry.glitch_rate`` above 0 some odometry records are glitches (``OdometryGlitches``); the
map sidecar then lists them as ``odometry_glitches``: ``[record index, kind]`` pairs, the index
counting the log's records from 0 (as the truth sidecar's rows).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from tqdm.auto import tqdm

from mazeslam.core.config import load_toml, require, to_mapping
from mazeslam.core.limits import duration_problem, maze_problem
from mazeslam.core.outputs import staged_file
from mazeslam.data import sidecars
from mazeslam.data.log import LogWriter
from mazeslam.sim.laser import LaserParams, VirtualLaser
from mazeslam.sim.maze import Maze, generate_maze, load_maze
from mazeslam.sim.odometry import OdometryGlitches, OdometryParams, WheelEncoders
from mazeslam.sim.policies import DriveParams, ExplorerPolicy
from mazeslam.sim.walls import wall_geometry
from mazeslam.sim.world import RobotParams, World


@dataclass(frozen=True)
class LoggerParams:
    """Record rates, named as in the exercise logger's Main.m.

    Attributes:
        scan_period: T_b_S, seconds between two scans.
        odometry_rate: F_O_U, odometry records per second.
        physics_rate: physics steps per second (not in the exercise; the simulator's time step).
        odometry_with_scan: read the encoders with every scan (an odometry record with the scan's
            timestamp precedes it); false: only every 1 / odometry_rate s.
        scan_phase: seconds added to every scan's time (the first scan at scan_period + scan_phase):
            where the scans fall between the odometry records when they are not read together.
    """

    scan_period: float = 0.75
    odometry_rate: float = 5.0
    physics_rate: float = 50.0
    odometry_with_scan: bool = True
    scan_phase: float = 0.0

    def __post_init__(self):
        require(self.scan_period > 0, f"logger scan_period must be positive, got {self.scan_period}")
        require(
            abs(self.scan_phase) < self.scan_period,
            f"logger scan_phase must be within +-scan_period ({self.scan_period} s), got {self.scan_phase}",
        )
        require(self.odometry_rate > 0, f"logger odometry_rate must be positive, got {self.odometry_rate}")
        require(self.physics_rate <= 10_000, f"logger physics_rate must be at most 10000 Hz, got {self.physics_rate}")
        require(
            self.physics_rate >= self.odometry_rate and self.physics_rate * self.scan_period >= 1,
            f"logger physics_rate {self.physics_rate} Hz must be at least the odometry rate and "
            f"one step per scan period",
        )


@dataclass(frozen=True)
class MazeParams:
    """The random maze drawn when no maze file is given (sizes in cells and metres)."""

    rows: int = 4
    cols: int = 4
    cell_size: float = 0.15
    wall_thickness: float = 0.01
    loop_fraction: float = 0.15

    def __post_init__(self):
        require(self.rows >= 1 and self.cols >= 1, f"maze rows and cols must be >= 1, got {self.rows} x {self.cols}")
        too_big = maze_problem(self.rows, self.cols)
        require(too_big is None, f"maze rows x cols: {too_big}")
        require(
            0 < self.wall_thickness < self.cell_size,
            f"maze wall_thickness {self.wall_thickness} m must be positive and below cell_size {self.cell_size} m",
        )
        require(0 <= self.loop_fraction <= 1, f"maze loop_fraction must be in [0, 1], got {self.loop_fraction}")


@dataclass(frozen=True)
class SimulationConfig:
    """Every simulator parameter; TOML sections ``[robot] [laser] [odometry] [logger] [drive] [maze]``.

    ``max_duration`` (s) bounds a run without an explicit duration, whose end is otherwise the end
    of the exploration tour.
    """

    robot: RobotParams = field(default_factory=RobotParams)
    laser: LaserParams = field(default_factory=LaserParams)
    odometry: OdometryParams = field(default_factory=OdometryParams)
    logger: LoggerParams = field(default_factory=LoggerParams)
    drive: DriveParams = field(default_factory=DriveParams)
    maze: MazeParams = field(default_factory=MazeParams)
    max_duration: float = 7200.0

    def __post_init__(self):
        require(self.max_duration > 0, f"max_duration must be positive, got {self.max_duration}")
        too_long = duration_problem(self.max_duration)
        require(too_long is None, f"max_duration: {too_long}")
        require(
            self.drive.cruise_speed <= self.robot.max_wheel_speed,
            f"drive cruise_speed {self.drive.cruise_speed} m/s exceeds the robot's max_wheel_speed "
            f"{self.robot.max_wheel_speed} m/s",
        )


def first_scan_time(logger: LoggerParams) -> float:
    """Seconds into a run at which ``simulate`` takes its first scan: the physics step at or after
    ``scan_period + scan_phase``."""
    return _first_scan_step(logger) * (1.0 / logger.physics_rate)


def _first_scan_step(logger: LoggerParams) -> int:
    """The physics step (1, 2, ...) ending with the first scan, in ``simulate``'s arithmetic."""
    dt = 1.0 / logger.physics_rate
    return max(1, math.ceil(logger.scan_period / dt + logger.scan_phase / dt - 1e-6))


def too_short_problem(seconds: float, logger: LoggerParams) -> str | None:
    """Why a run of ``seconds`` would write no scan (a log without scans maps nothing), or None."""
    if (_first_scan_step(logger) - 1) * (1.0 / logger.physics_rate) < seconds - 1e-9:  # ``simulate``'s loop
        return None
    first = first_scan_time(logger)
    phase = f" + scan_phase {logger.scan_phase:g} s" if logger.scan_phase else ""
    return (
        f"{seconds:g} s is too short for one scan: the first is taken at {first:.6g} s "
        f"(logger scan_period {logger.scan_period:g} s{phase}); at least {first:.6g} s"
    )


def load_config(path: str | Path | None) -> SimulationConfig:
    """The simulator configuration from a TOML file, or the defaults when ``path`` is None."""
    return SimulationConfig() if path is None else load_toml(SimulationConfig, path)


@dataclass
class SimulationResult:
    """What a run wrote, and the same data in memory.

    ``times`` (R,) s and ``poses`` (R, 3) are the true poses at every log record; ``maze`` the maze.
    """

    log_path: Path
    truth_path: Path
    map_path: Path
    times: np.ndarray
    poses: np.ndarray
    maze: Maze
    policy_finished: bool


def simulate(
    out: str | Path,
    config: SimulationConfig | None = None,
    maze: Maze | str | Path | None = None,
    seed: int = 0,
    duration: float | None = None,
    policy=None,
    progress: bool = True,
) -> SimulationResult:
    """Simulate one run and write ``out`` (course log), ``*.truth.csv`` and ``*.map.json`` beside it.

    Args:
        out: path of the log to write, e.g. ``runs/demo.log``.
        config: simulator parameters (defaults: ``SimulationConfig()``).
        maze: a ``Maze``, a maze text file, or None for a random maze drawn from ``seed`` and
            ``config.maze``.
        seed: seeds every random draw (maze, driving, slip, laser noise); the same seed and
            parameters give the same bytes.
        duration: seconds to simulate; None runs until the exploration tour is complete (bounded
            by ``config.max_duration``). At least one scan's time (``first_scan_time``): a
            shorter run is refused before any file is written.
        policy: a callable ``(t, pose) -> (speed, turn_rate)``; default: the maze explorer.
        progress: show a progress bar on a terminal.
    """
    config = config or SimulationConfig()
    if duration is not None:
        require(duration > 0, f"duration must be positive, got {duration}")
        too_long = duration_problem(duration)
        require(too_long is None, f"duration: {too_long}")
    too_short = too_short_problem(duration if duration is not None else config.max_duration, config.logger)
    require(too_short is None, f"{'duration' if duration is not None else 'max_duration'}: {too_short}")
    out = Path(out)
    with staged_file(out) as staged:  # a full disk or an interrupt leaves the last log and its sidecars as they were
        result = _simulate_into(staged, config, maze, seed, duration, policy, progress)
    return dataclasses.replace(
        result, log_path=out, truth_path=sidecars.truth_path(out), map_path=sidecars.map_path(out)
    )


def _simulate_into(
    out: Path, config: SimulationConfig, maze, seed: int, duration: float | None, policy, progress: bool
) -> SimulationResult:
    """``simulate``'s run, its log written to ``out`` (a staged path) with the sidecars beside it."""
    maze_rng, drive_rng, slip_rng, laser_rng, glitch_rng = (
        np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(5)
    )
    maze = _resolve_maze(maze, config.maze, maze_rng, seed)
    walls = wall_geometry(maze)
    start_pose = np.array([*maze.cell_center(*maze.start_cell), 0.0])
    world = World(walls.boxes, config.robot, start_pose)
    encoders = WheelEncoders(config.robot, config.odometry, slip_rng)
    glitches = OdometryGlitches(config.odometry, glitch_rng)
    laser = VirtualLaser(config.laser, walls.surfaces)
    policy = policy or ExplorerPolicy(maze, config.drive, drive_rng)

    logger = config.logger
    dt = 1.0 / logger.physics_rate
    end_time = duration if duration is not None else config.max_duration
    steps_per_odometry = 1.0 / (logger.odometry_rate * dt)
    steps_per_scan = logger.scan_period / dt
    record_times: list[float] = []
    record_poses: list[np.ndarray] = []
    glitched: list[tuple[int, str]] = []  # (record index, kind) of the odometry glitches written
    bar = tqdm(
        total=round(end_time if duration is not None else 0) or None,
        unit="sim s",
        disable=not progress,
        desc=f"simulate {out.name}",
    )
    with LogWriter(out, config.laser.beams) as writer:
        step, scans = 0, 0
        next_odometry, next_scan = steps_per_odometry, steps_per_scan + logger.scan_phase / dt
        while step * dt < end_time - 1e-9 and (duration is not None or not policy.done):
            speed, turn_rate = policy(step * dt, world.pose)
            left_speed, right_speed = config.robot.wheel_speeds(speed, turn_rate)
            world.step(*encoders.drive(left_speed, right_speed, dt), dt)
            step += 1
            t = step * dt
            scan_due = step >= next_scan - 1e-6
            odometry_due = step >= next_odometry - 1e-6
            if odometry_due or (scan_due and logger.odometry_with_scan):
                if odometry_due:
                    next_odometry += steps_per_odometry
                distance, turn, glitch = glitches.apply(*encoders.read())
                if glitch:
                    glitched.append((len(record_times), glitch))
                writer.write_odometry(t, distance, turn)
                record_times.append(t)
                record_poses.append(world.pose)
            if scan_due:
                next_scan += steps_per_scan
                writer.write_scan(t, laser.scan(world.pose, laser_rng))
                scans += 1
                record_times.append(t)
                record_poses.append(world.pose)
            if step % round(logger.physics_rate) == 0:
                bar.update(1)
    bar.close()
    if not scans:  # the policy finished before the first scan: a log without scans maps nothing
        out.unlink(missing_ok=True)
        raise ValueError(
            f"the policy finished at {step * dt:g} s, before the first scan at {first_scan_time(logger):g} s: "
            f"nothing written; give a duration of at least {first_scan_time(logger):g} s, or a longer policy"
        )
    times, poses = np.array(record_times), np.array(record_poses).reshape(-1, 3)
    truth_file, map_file = sidecars.truth_path(out), sidecars.map_path(out)
    sidecars.write_truth(truth_file, times, poses)
    sensor = config.laser.sensor_mapping()
    sidecars.write_map(
        map_file,
        walls.surfaces,
        walls.corners,
        sensor,
        corner_convex=walls.corner_convex.tolist(),
        start_pose=start_pose.tolist(),
        seed=seed,
        duration=duration,
        maze={
            "name": maze.name,
            "rows": maze.rows,
            "cols": maze.cols,
            "cell_size": maze.cell_size,
            "wall_thickness": maze.wall_thickness,
            "seed": maze.seed,
            "text": maze.to_text(),
        },
        parameters=to_mapping(config),
        **({"odometry_glitches": glitched} if config.odometry.glitch_rate else {}),
    )
    return SimulationResult(out, truth_file, map_file, times, poses, maze, bool(getattr(policy, "done", True)))


def _resolve_maze(maze, params: MazeParams, rng: np.random.Generator, seed: int) -> Maze:
    if isinstance(maze, Maze):
        return maze
    if maze is not None and str(maze) != "random":
        return load_maze(maze)
    random_maze = generate_maze(
        params.rows, params.cols, rng, params.cell_size, params.wall_thickness, params.loop_fraction
    )
    random_maze.seed = seed
    return random_maze
