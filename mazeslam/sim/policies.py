"""Drivers for the simulated robot: a maze explorer and scripted open-loop commands.

A policy is called once per physics step with the time (s) and the robot's true pose and returns
the body command ``(speed m/s, turn_rate rad/s)``. The explorer is an oracle driver: it steers by
the true pose, which the log never contains (the log only holds the noisy odometry and scans).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mazeslam.core.config import require
from mazeslam.core.geometry import wrap_angle
from mazeslam.sim.maze import Maze


@dataclass(frozen=True)
class DriveParams:
    """How the explorer drives.

    Attributes:
        cruise_speed: forward speed on straight stretches, m/s.
        turn_rate: fastest turn, rad/s.
        turn_in_place_above: heading error (rad) above which the robot stops and turns on the spot.
        waypoint_tolerance: distance (m) at which a cell centre counts as reached.
        steering_gain: turn rate per radian of heading error, 1/s.
    """

    cruise_speed: float = 0.05
    turn_rate: float = 1.0
    turn_in_place_above: float = 0.3
    waypoint_tolerance: float = 0.015
    steering_gain: float = 3.0

    def __post_init__(self):
        for name in ("cruise_speed", "turn_rate", "turn_in_place_above", "waypoint_tolerance", "steering_gain"):
            require(getattr(self, name) > 0, f"drive {name} must be positive, got {getattr(self, name)}")


def exploration_tour(maze: Maze, rng: np.random.Generator) -> list[tuple[int, int]]:
    """Cells to drive through, in order, so that the robot sees every cell and comes back.

    A depth-first walk from the start cell (neighbours in random order) visits every reachable cell
    and backtracks through corridors it has seen, which re-observes old corners; the tour then
    returns to the start by the shortest path, closing the loop. Consecutive cells are neighbours.
    """
    start = maze.start_cell
    tour = [start]
    visited = {start}
    stack = [start]
    while stack:
        cell = stack[-1]
        options = [n for n in maze.neighbours(*cell) if n not in visited]
        if options:
            nxt = options[rng.integers(len(options))]
            visited.add(nxt)
            stack.append(nxt)
        else:
            stack.pop()
            if not stack:
                break
            nxt = stack[-1]
        tour.append(nxt)
    return tour + shortest_path(maze, tour[-1], start)[1:]


def shortest_path(maze: Maze, source, target) -> list[tuple[int, int]]:
    """Cells from ``source`` to ``target`` inclusive along the fewest cells (breadth-first search)."""
    previous = {source: None}
    queue = deque([source])
    while queue:
        cell = queue.popleft()
        if cell == target:
            break
        for n in maze.neighbours(*cell):
            if n not in previous:
                previous[n] = cell
                queue.append(n)
    if target not in previous:
        raise ValueError(f"cell {target} cannot be reached from {source}")
    path = [target]
    while path[-1] != source:
        path.append(previous[path[-1]])
    return path[::-1]


def steer_to(pose: np.ndarray, target: np.ndarray, params: DriveParams) -> tuple[float, float]:
    """(speed m/s, turn rate rad/s) that take a robot at ``pose`` towards the point ``target``:
    turn on the spot while the heading is off by more than ``turn_in_place_above``, else drive
    with proportional steering, slowing down near the target."""
    offset = np.asarray(target, dtype=float) - pose[:2]
    error = wrap_angle(np.arctan2(offset[1], offset[0]) - pose[2])
    turn = float(np.clip(params.steering_gain * error, -params.turn_rate, params.turn_rate))
    if abs(error) > params.turn_in_place_above:
        return 0.0, turn
    speed = min(params.cruise_speed, params.steering_gain * np.hypot(*offset)) * np.cos(error)
    return float(speed), turn


class ExplorerPolicy:
    """Follows the exploration tour from cell centre to cell centre, then keeps touring random cells.

    ``done`` becomes True when the tour (every cell, then back to the start) is complete.
    """

    def __init__(self, maze: Maze, params: DriveParams, rng: np.random.Generator):
        self.maze = maze
        self.params = params
        self.rng = rng
        self.waypoints = deque(_merge_straight(exploration_tour(maze, rng)))
        self.done = False
        self._current = self.waypoints.popleft()

    def __call__(self, t: float, pose: np.ndarray) -> tuple[float, float]:
        if np.hypot(*(self.maze.cell_center(*self._current) - pose[:2])) < self.params.waypoint_tolerance:
            self._next_waypoint()
        return steer_to(pose, self.maze.cell_center(*self._current), self.params)

    def _next_waypoint(self) -> None:
        if not self.waypoints:
            self.done = True
            goal = (int(self.rng.integers(self.maze.rows)), int(self.rng.integers(self.maze.cols)))
            self.waypoints.extend(_merge_straight(shortest_path(self.maze, self._current, goal))[1:])
        if self.waypoints:
            self._current = self.waypoints.popleft()


def _merge_straight(cells: list[tuple[int, int]]) -> list[tuple[int, int]]:
    """Drop cells in the middle of straight runs, so the robot drives through them without stopping."""
    kept = [cells[0]]
    for before, cell, after in zip(cells, cells[1:], cells[2:]):
        if (cell[0] - before[0], cell[1] - before[1]) != (after[0] - cell[0], after[1] - cell[1]):
            kept.append(cell)
    if len(cells) > 1:
        kept.append(cells[-1])
    return kept


class ScriptedPolicy:
    """Open-loop commands: a list of ``(duration s, speed m/s, turn_rate rad/s)`` played in order.

    ``done`` becomes True after the last command; the robot then stands still.
    """

    def __init__(self, commands):
        self.commands = [tuple(float(v) for v in command) for command in commands]
        for duration, _, _ in self.commands:
            require(duration > 0, f"scripted command durations must be positive, got {duration}")
        self.ends = np.cumsum([command[0] for command in self.commands])
        self.done = not self.commands

    def __call__(self, t: float, pose: np.ndarray) -> tuple[float, float]:
        index = int(np.searchsorted(self.ends, t, side="right"))
        if index >= len(self.commands):
            self.done = True
            return 0.0, 0.0
        return self.commands[index][1], self.commands[index][2]


def load_commands(path: str | Path) -> ScriptedPolicy:
    """A ``ScriptedPolicy`` from a text file of ``duration speed turn_rate`` lines ('#' comments)."""
    from mazeslam.core.config import read_text

    path = Path(path)
    commands = []
    for number, line in enumerate(read_text(path, "commands file").splitlines(), start=1):
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        parts = line.replace(",", " ").split()
        try:
            if len(parts) != 3:
                raise ValueError(f"expected 'duration speed turn_rate', got {len(parts)} values")
            values = [float(v) for v in parts]
            if not all(math.isfinite(v) and abs(v) <= 1e6 for v in values):
                raise ValueError(f"values must be finite numbers of sane size, got {' '.join(parts)}")
            commands.append(values)
        except ValueError as error:
            raise ValueError(f"{path}:{number}: {error}") from error
    try:
        return ScriptedPolicy(commands)
    except ValueError as error:
        raise ValueError(f"{path}: {error}") from error
