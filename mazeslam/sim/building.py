"""A small simulated building for the grid filter's tests and benchmark: a ring of 2 m corridors
around a block, with pillars along the walls, driven around with biased wheel odometry and a
SICK-like front laser (181 beams over 180 degrees).

World frame, metres and radians. The robot follows the corridor's centre line, turning in place
at the corners, and goes on past its start, so that a filter must close the loop.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mazeslam.core.beams import BeamGeometry
from mazeslam.core.geometry import advance_pose, wrap_angle
from mazeslam.data import sidecars
from mazeslam.data.log import LogWriter
from mazeslam.sim.laser import LaserParams, VirtualLaser

#: The laser: a front fan from -90 to +90 degrees, one beam a degree, centimetre noise.
LASER = LaserParams(
    beams=181,
    max_range=20.0,
    range_noise_std=0.01,
    geometry=BeamGeometry(first_beam_angle=-np.pi / 2, field_of_view=np.pi),
)


def _box(x_low: float, y_low: float, x_high: float, y_high: float) -> list[list[float]]:
    """The four wall segments [x1, y1, x2, y2] of an axis-aligned box, m."""
    corners = [(x_low, y_low), (x_high, y_low), (x_high, y_high), (x_low, y_high)]
    return [[*corners[k], *corners[(k + 1) % 4]] for k in range(4)]


def building_walls(length: float = 16.0, width: float = 10.0, corridor: float = 2.0) -> np.ndarray:
    """Wall segments (W, 4) of the ring corridor: the outer walls ``length`` x ``width`` (m) from
    the origin, the inner block ``corridor`` metres in from them, and pillars (0.4 m) against the
    outer walls at irregular places, so that no stretch of corridor looks like the next."""
    walls = _box(0.0, 0.0, length, width) + _box(corridor, corridor, length - corridor, width - corridor)
    for x in (4.3, 9.1, 12.2):
        walls += _box(x, 0.0, x + 0.4, 0.3)
    for x in (3.1, 6.2, 11.0):
        walls += _box(x, width - 0.3, x + 0.4, width)
    for y in (3.5, 6.8):
        walls += _box(length - 0.3, y, length, y + 0.4)
    walls += _box(0.0, 5.7, 0.3, 6.1)
    return np.array(walls)


@dataclass(frozen=True)
class SimulatedLog:
    """A simulated log: the file, its true pose (R, 3) at every record, the start pose (3,) and the
    laser's beam geometry."""

    path: Path
    truth: np.ndarray
    start_pose: np.ndarray
    geometry: BeamGeometry


def simulate_building_log(
    path: str | Path,
    laps: float = 1.3,
    step: float = 0.1,
    scan_every: int = 5,
    heading_bias: float = 0.02,
    seed: int = 0,
) -> SimulatedLog:
    """Drive ``laps`` times round the corridor ring of ``building_walls`` and write the log, with its
    truth and map sidecars (the true pose at every record; the walls, the laser, the start pose).

    Odometry records come every ``step`` metres (or radians, turning in place at the corners): the
    true increment with 2 % distance noise and a heading error of ``heading_bias`` rad per metre
    driven, so dead reckoning bends. A scan follows every ``scan_every``-th odometry record.
    """
    rng = np.random.default_rng(seed)
    walls = building_walls()
    laser = VirtualLaser(LASER, walls)
    start = np.array([1.0, 1.0, 0.0])
    moves = _centre_line_moves(walls, laps, step)
    truth, times, pose, time = [], [], start, 0.0
    with LogWriter(path, LASER.beams) as writer:
        for index, (distance, turn) in enumerate(moves):
            pose = advance_pose(pose, distance, turn)
            time += 0.1
            measured = distance * (1 + 0.02 * rng.standard_normal())
            writer.write_odometry(time, measured, turn + heading_bias * abs(distance) + 0.002 * rng.standard_normal())
            truth.append(pose)
            times.append(time)
            if (index + 1) % scan_every == 0:
                writer.write_scan(time, laser.scan(pose, rng))
                truth.append(pose)
                times.append(time)
    sidecars.write_truth(sidecars.truth_path(path), np.array(times), np.array(truth))
    sidecars.write_map(
        sidecars.map_path(path),
        walls,
        np.empty((0, 2)),
        LASER.sensor_mapping(),
        start_pose=start.tolist(),
        source="mazeslam.sim.building",  # what pipeline.log_kinds tells it by
    )
    return SimulatedLog(Path(path), np.array(truth), start, LASER.geometry)


def _centre_line_moves(walls: np.ndarray, laps: float, step: float) -> list[tuple[float, float]]:
    """Increments (distance m, turn rad) along the ring's centre line, anticlockwise from (1, 1)."""
    length, width = walls[0, 2], walls[1, 3]
    sides = [length - 2.0, width - 2.0, length - 2.0, width - 2.0]
    moves: list[tuple[float, float]] = []
    travelled, total = 0.0, laps * sum(sides)
    for side in range(8):
        for _ in range(int(round(sides[side % 4] / step))):
            if travelled >= total:
                return moves
            moves.append((step, 0.0))
            travelled += step
        turns = int(round(np.pi / 2 / step))
        moves += [(0.0, wrap_angle(np.pi / 2 / turns))] * turns
    return moves
