"""Thick-wall geometry of a maze: the solid blocks, the surfaces a laser hits, the true corners.

Walls of thickness t are centred on the grid lines. Cutting the plane at ``k s ± t/2`` along both
axes gives a grid of (2R+1) x (2C+1) rectangular blocks: even index bands hold walls and posts,
odd bands hold cell interiors. A block is solid when it is a wall that exists, or a post that
touches one. Everything else follows from that block grid:

* surfaces — the edges between a solid and a free block, merged into maximal straight segments;
* corners — grid vertices where the solid blocks around them turn: one solid of four is a convex
  corner (a wall end seen from the corridor), three of four a concave (inside) corner.

The space outside the maze counts as solid; the outer boundary is closed, so no surface faces it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mazeslam.sim.maze import Maze


@dataclass(frozen=True)
class WallGeometry:
    """Geometry of a maze's thick walls, all in world metres.

    Attributes:
        surfaces: (W, 4) segments ``[x1, y1, x2, y2]``, the wall faces that border free space.
        corners: (K, 2) corner positions ``[x, y]``.
        corner_convex: (K,) bool, True for convex corners (wall ends), False for inside corners.
        boxes: (B, 4) solid rectangles ``[xmin, ymin, xmax, ymax]`` whose union is the walls.
    """

    surfaces: np.ndarray
    corners: np.ndarray
    corner_convex: np.ndarray
    boxes: np.ndarray


def solid_blocks(maze: Maze) -> np.ndarray:
    """Which blocks of the (2R+1, 2C+1) block grid are solid; index [i, j] with i along y, j along x."""
    rows, cols = maze.rows, maze.cols
    solid = np.zeros((2 * rows + 1, 2 * cols + 1), dtype=bool)
    solid[0::2, 1::2] = maze.horizontal
    solid[1::2, 0::2] = maze.vertical
    posts = np.zeros((rows + 1, cols + 1), dtype=bool)
    posts[:, :-1] |= maze.horizontal
    posts[:, 1:] |= maze.horizontal
    posts[:-1, :] |= maze.vertical
    posts[1:, :] |= maze.vertical
    solid[0::2, 0::2] = posts
    return solid


def block_edges(count: int, cell_size: float, thickness: float) -> np.ndarray:
    """Coordinates (metres) of the 2*count + 2 block boundaries along one axis of ``count`` cells."""
    lines = np.arange(count + 1) * cell_size
    edges = np.empty(2 * count + 2)
    edges[0::2] = lines - thickness / 2
    edges[1::2] = lines + thickness / 2
    return edges


def wall_geometry(maze: Maze) -> WallGeometry:
    """Surfaces, corners and collision boxes of ``maze``'s walls."""
    solid = solid_blocks(maze)
    xs = block_edges(maze.cols, maze.cell_size, maze.wall_thickness)
    ys = block_edges(maze.rows, maze.cell_size, maze.wall_thickness)
    corners, convex = _corners(solid, xs, ys)
    return WallGeometry(_surfaces(solid, xs, ys), corners, convex, _boxes(solid, xs, ys))


def _surfaces(solid: np.ndarray, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    segments = []
    # Vertical faces: between blocks (i, j) and (i, j+1), on x = xs[j+1]; merged along i.
    change = solid[:, :-1] != solid[:, 1:]
    side = solid[:, :-1]  # True: solid on the left of the face
    for j in range(change.shape[1]):
        for start, stop in _runs(change[:, j], side[:, j]):
            segments.append([xs[j + 1], ys[start], xs[j + 1], ys[stop]])
    # Horizontal faces: between blocks (i, j) and (i+1, j), on y = ys[i+1]; merged along j.
    change = solid[:-1, :] != solid[1:, :]
    side = solid[:-1, :]
    for i in range(change.shape[0]):
        for start, stop in _runs(change[i, :], side[i, :]):
            segments.append([xs[start], ys[i + 1], xs[stop], ys[i + 1]])
    return np.array(segments, dtype=float).reshape(-1, 4)


def _runs(is_face: np.ndarray, orientation: np.ndarray):
    """Maximal runs [start, stop) of consecutive faces with the same orientation (solid side)."""
    start = None
    for k in range(len(is_face) + 1):
        continues = k < len(is_face) and is_face[k] and start is not None and orientation[k] == orientation[start]
        if start is not None and not continues:
            yield start, k
            start = None
        if start is None and k < len(is_face) and is_face[k]:
            start = k


def _corners(solid: np.ndarray, xs: np.ndarray, ys: np.ndarray):
    padded = np.pad(solid, 1, constant_values=True)  # outside the maze counts as solid
    around = (
        padded[:-1, :-1].astype(int) + padded[:-1, 1:] + padded[1:, :-1] + padded[1:, 1:]
    )  # (2R+2, 2C+2): solid blocks around each block-grid vertex
    diagonal = (padded[:-1, :-1] == padded[1:, 1:]) & (padded[:-1, 1:] == padded[1:, :-1]) & (around == 2)
    is_corner = (around == 1) | (around == 3) | diagonal
    i, j = np.nonzero(is_corner)
    corners = np.column_stack([xs[j], ys[i]])
    return corners, around[i, j] != 3


def _boxes(solid: np.ndarray, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    """Solid blocks merged along x into rectangles [xmin, ymin, xmax, ymax]."""
    boxes = []
    for i in range(solid.shape[0]):
        for start, stop in _runs(solid[i], np.ones(solid.shape[1], dtype=bool)):
            boxes.append([xs[start], ys[i], xs[stop], ys[i + 1]])
    return np.array(boxes, dtype=float).reshape(-1, 4)


class WallsInSight:
    """Per maze cell, the wall surfaces that a beam of at most ``reach`` metres from anywhere in
    the cell can meet first (for ``RayCaster.hits``). A straight beam moves monotonically along x
    and along y, crossing from cell to cell only through open walls, and every cell it passes
    lies within ``reach`` of where it started; so it meets a surface that touches one of the cells
    joined to its own by such a monotone path of cells (one per quadrant of directions). A cell
    here spans its wall bands (``k s -+ t/2``) too, so a sensor standing in an open wall's gap
    belongs to either cell beside it. Computed per cell when first asked, from the surfaces that
    touch each cell (listed once, in memory and time proportional to the maze's size: a 100 x 100
    maze takes a fraction of a second, not the cells x surfaces table it used to, 4 GB at 200 x 200).

    Args:
        maze: the maze; ``surfaces``: its (W, 4) wall surfaces (``wall_geometry``), metres;
        ``reach``: metres (the laser's ``max_range``).
    """

    def __init__(self, maze: Maze, surfaces: np.ndarray, reach: float):
        self.maze, self.reach = maze, reach
        s, t = maze.cell_size, maze.wall_thickness
        margin = t / 2 + 1e-9  # the wall bands around each cell, and rounding
        box_low, box_high = np.minimum(surfaces[:, :2], surfaces[:, 2:]), np.maximum(surfaces[:, :2], surfaces[:, 2:])
        # Per surface, a range of cells around its box (a cell more on each side than it can
        # touch), then the (cell, surface) pairs where it touches the cell's rectangle, bands
        # included: ``low <= box_high`` and ``box_low <= high`` along x and y.
        limits = np.array([maze.cols - 1, maze.rows - 1])
        first = np.clip(np.floor((box_low - margin) / s).astype(np.int64) - 2, 0, limits)  # (W, 2) col, row
        last = np.clip(np.floor((box_high + margin) / s).astype(np.int64) + 1, 0, limits)
        spans = last - first + 1
        counts = spans[:, 0] * spans[:, 1]
        surface = np.repeat(np.arange(len(surfaces)), counts)
        k = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
        col = first[surface, 0] + k % spans[surface, 0]
        row = first[surface, 1] + k // spans[surface, 0]
        touches = (
            (box_low[surface, 0] <= (col + 1) * s + margin)
            & (box_high[surface, 0] >= col * s - margin)
            & (box_low[surface, 1] <= (row + 1) * s + margin)
            & (box_high[surface, 1] >= row * s - margin)
        )
        cell, surface = (row * maze.cols + col)[touches], surface[touches]
        order = np.argsort(cell, kind="stable")
        self._touching = surface[order]  # the surfaces touching each cell (row-major), cell after cell
        self._starts = np.searchsorted(cell[order], np.arange(maze.rows * maze.cols + 1))
        self._cache: dict[tuple[int, int], np.ndarray] = {}

    def walls(self, x: float, y: float) -> np.ndarray:
        """Indices of the surfaces a beam from (x, y) (m) can meet first."""
        maze = self.maze  # the cell (row, col) of (x, y) as ``Maze.cell_of``, in plain floats
        cell = (
            min(max(math.floor(y / maze.cell_size), 0), maze.rows - 1),
            min(max(math.floor(x / maze.cell_size), 0), maze.cols - 1),
        )
        if cell not in self._cache:
            joined = set().union(*(self._monotone(cell, up, right) for up in (1, -1) for right in (1, -1)))
            starts, cols = self._starts, self.maze.cols
            touching = [self._touching[starts[r * cols + c] : starts[r * cols + c + 1]] for r, c in joined]
            self._cache[cell] = np.unique(np.concatenate(touching))
        return self._cache[cell]

    def _monotone(self, start: tuple[int, int], up: int, right: int) -> set[tuple[int, int]]:
        """The cells reached from ``start`` stepping only ``up`` rows (+-1) or ``right`` columns
        (+-1) through open walls, without leaving ``reach`` of it."""
        maze, s, t = self.maze, self.maze.cell_size, self.maze.wall_thickness
        seen, frontier = {start}, [start]
        while frontier:
            row, col = frontier.pop()
            steps = []
            if not maze.horizontal[row + (up > 0), col]:
                steps.append((row + up, col))
            if not maze.vertical[row, col + (right > 0)]:
                steps.append((row, col + right))
            for near in steps:
                # The gap between the two cells' rectangles (bands included), metres.
                gap = math.hypot(*(max(0.0, (abs(a - b) - 1) * s - t) for a, b in zip(near, start)))
                if near not in seen and gap <= self.reach:
                    seen.add(near)
                    frontier.append(near)
        return seen
