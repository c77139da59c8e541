"""Batched maze physics: many robots in many mazes of one shape, stepped together in numpy.

The mazes are held as their solid-block grids (``walls.solid_blocks``): E grids of (2R+1, 2C+1)
blocks sharing the block edges ``xs`` (2C+2,) and ``ys`` (2R+2,), metres. On them:

* ``MazeGrids.cast``: one ray cast for every robot's beams. Each ray walks through its grid from
  block to block across the nearer block edge (a digital differential analyser) until it enters a
  solid block or passes ``max_range``: exact for the maze's axis-aligned thick walls, and cheap,
  since a ray in a maze crosses few blocks before it meets a wall.
* ``push_out``: robot discs pushed out of the solid blocks they overlap, along the
  shortest way out, as ``World`` does with pymunk's contacts: a disc slides along a wall it drives
  against and never passes through one (a step moves it much less than its radius).
* ``MazeGrids.face_bins``: where each beam landed, as a bin of ``spacing`` metres on a wall face,
  to count the wall surface seen.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mazeslam.envs.maze import Maze
from mazeslam.envs.walls import block_edges, solid_blocks

#: Smallest |direction component| of a ray; smaller ones are raised to it (the ray then never
#: reaches the next edge along that axis within any range).
TINY_COMPONENT = 1e-12


@dataclass
class MazeGrids:
    """The solid-block grids of E mazes with the same rows, columns, cell size and wall thickness.

    Attributes:
        solid: (E, 2R+1, 2C+1) bool, block [e, i, j] of maze e (i along y, j along x) is solid.
        xs: (2C+2,) block edges along x, metres; ``ys``: (2R+2,) along y.
        cell_size, thickness: metres.
    """

    solid: np.ndarray
    xs: np.ndarray
    ys: np.ndarray
    cell_size: float
    thickness: float

    @classmethod
    def like(cls, maze: Maze, count: int) -> MazeGrids:
        """Grids for ``count`` mazes shaped like ``maze`` (all blocks solid until ``set``)."""
        rows, cols, s, t = maze.rows, maze.cols, maze.cell_size, maze.wall_thickness
        solid = np.ones((count, 2 * rows + 1, 2 * cols + 1), dtype=bool)
        return cls(solid, block_edges(cols, s, t), block_edges(rows, s, t), s, t)

    def fits(self, maze: Maze) -> bool:
        """Whether ``maze`` has these grids' shape, cell size and wall thickness."""
        return self.solid.shape[1:] == (2 * maze.rows + 1, 2 * maze.cols + 1) and (
            maze.cell_size,
            maze.wall_thickness,
        ) == (self.cell_size, self.thickness)

    def set(self, env: int, maze: Maze) -> None:
        """Make grid ``env`` that of ``maze`` (which must ``fit``)."""
        if not self.fits(maze):
            raise ValueError("every maze of a vector must have the same rows, cols, cell size and wall thickness")
        self.solid[env] = solid_blocks(maze)

    def blocks_of(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Block indices (i, j) of the points (x, y) (metres), each clipped to the grid."""
        height, width = self.solid.shape[1:]
        return (
            np.minimum(np.maximum(_band(y, self.cell_size, self.thickness), 0), height - 1),
            np.minimum(np.maximum(_band(x, self.cell_size, self.thickness), 0), width - 1),
        )

    # -- ray casting ------------------------------------------------------------------------
    def cast(
        self,
        envs: np.ndarray,
        x: np.ndarray,
        y: np.ndarray,
        heading: np.ndarray,
        bearings: np.ndarray,
        max_range: float,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Cast beams from K sensors, sensor k at (x[k], y[k]) (m) facing ``heading[k]`` (rad) in maze
        ``envs[k]``, along ``bearings`` (N,) (rad, sensor frame).

        Returns ``(distances, faces, along)``, all (K, N): metres to the first wall (``inf`` where
        none lies within ``max_range``); the wall face hit: ``f >= 0`` the vertical face on
        ``x = xs[f]``, ``f < 0`` the horizontal face on ``y = ys[-1 - f]``; and where along that
        face, metres (y on a vertical face, x on a horizontal one). Faces and ``along`` are
        meaningless where the distance is inf.
        """
        count, beams = len(envs), len(bearings)
        cos_h, sin_h = np.cos(heading)[:, None], np.sin(heading)[:, None]
        dx = (cos_h * np.cos(bearings) - sin_h * np.sin(bearings)).ravel()
        dy = (sin_h * np.cos(bearings) + cos_h * np.sin(bearings)).ravel()
        dx[np.abs(dx) < TINY_COMPONENT] = TINY_COMPONENT
        dy[np.abs(dy) < TINY_COMPONENT] = TINY_COMPONENT
        height, width = self.solid.shape[1:]
        i, j = (np.repeat(index, beams) for index in self.blocks_of(x, y))
        step_x, step_y = np.where(dx > 0, 1, -1), np.where(dy > 0, 1, -1)
        # Per active ray: ray index, next x edge, next y edge, flat block index, x step, y step, flat y step.
        ints = np.stack(
            [
                np.arange(count * beams),
                j + (step_x > 0),
                i + (step_y > 0),
                np.repeat(envs * height * width, beams) + i * width + j,
                step_x,
                step_y,
                step_y * width,
            ]
        )
        origin_x, origin_y = np.repeat(x, beams), np.repeat(y, beams)
        floats = np.stack([origin_x, origin_y, 1 / dx, 1 / dy])
        distances = np.full(count * beams, np.inf)
        faces = np.zeros(count * beams, dtype=np.int64)
        solid = self.solid.ravel()
        while ints.shape[1]:
            ray, edge_x, edge_y, block, step_x, step_y, step_block_y = ints
            to_x = (self.xs[edge_x] - floats[0]) * floats[2]  # distance to the next x edge
            to_y = (self.ys[edge_y] - floats[1]) * floats[3]
            across_x = to_x <= to_y
            face = np.where(across_x, edge_x, -1 - edge_y)
            distance = np.where(across_x, to_x, to_y)
            edge_x += step_x * across_x
            edge_y += step_y * ~across_x
            block += np.where(across_x, step_x, step_block_y)
            done = solid[block] | (distance > max_range)
            distances[ray[done]] = distance[done]
            faces[ray[done]] = face[done]
            ints, floats = ints[:, ~done], floats[:, ~done]
        distances[distances > max_range] = np.inf
        along = np.where(faces >= 0, origin_y + distances * dy, origin_x + distances * dx)
        return distances.reshape(count, beams), faces.reshape(count, beams), along.reshape(count, beams)

    # -- wall faces seen --------------------------------------------------------------------
    def bin_counts(self, spacing: float) -> tuple[int, int]:
        """Bins of ``spacing`` metres along a vertical and along a horizontal block edge."""
        return (math.ceil((self.ys[-1] - self.ys[0]) / spacing), math.ceil((self.xs[-1] - self.xs[0]) / spacing))

    def bin_total(self, spacing: float) -> int:
        """How many ``face_bins`` there are."""
        along_y, along_x = self.bin_counts(spacing)
        return len(self.xs) * along_y + len(self.ys) * along_x

    def bin_points(self, bins: np.ndarray, spacing: float) -> np.ndarray:
        """(K, 2) centres (m) of ``face_bins`` ``bins`` (K,)."""
        along_y, along_x = self.bin_counts(spacing)
        vertical = bins < len(self.xs) * along_y
        line, step = np.where(vertical, np.divmod(bins, along_y), np.divmod(bins - len(self.xs) * along_y, along_x))
        centre = (step + 0.5) * spacing
        return np.column_stack(
            [
                np.where(vertical, self.xs[np.minimum(line, len(self.xs) - 1)], self.xs[0] + centre),
                np.where(vertical, self.ys[0] + centre, self.ys[np.minimum(line, len(self.ys) - 1)]),
            ]
        )

    def face_bins(self, faces: np.ndarray, along: np.ndarray, spacing: float) -> np.ndarray:
        """Bin index (same shape as ``faces``) of the wall points ``along`` (m) ``faces`` (as
        ``cast`` returns them): bins of ``spacing`` metres along each block edge, vertical edges
        first, then horizontal ones."""
        along_y, along_x = self.bin_counts(spacing)
        vertical = faces >= 0
        step = ((along - np.where(vertical, self.ys[0], self.xs[0])) / spacing).astype(np.int64)
        step = np.minimum(np.maximum(step, 0), np.where(vertical, along_y, along_x) - 1)
        return np.where(vertical, faces * along_y + step, len(self.xs) * along_y + (-1 - faces) * along_x + step)

    def wall_bins(self, env: int, spacing: float) -> np.ndarray:
        """Which bins (``face_bins``) of maze ``env`` have their centre on a wall face: (bins,) bool."""
        along_y, along_x = self.bin_counts(spacing)
        padded = np.pad(self.solid[env], 1, constant_values=True)  # outside the maze counts as solid
        vertical_faces = padded[1:-1, :-1] != padded[1:-1, 1:]  # (2R+1, 2C+2): block row, x edge
        horizontal_faces = padded[:-1, 1:-1] != padded[1:, 1:-1]  # (2R+2, 2C+1): y edge, block column
        row = self.blocks_of(np.zeros(along_y), self.ys[0] + (np.arange(along_y) + 0.5) * spacing)[0]
        column = self.blocks_of(self.xs[0] + (np.arange(along_x) + 0.5) * spacing, np.zeros(along_x))[1]
        return np.concatenate([vertical_faces[row].T.ravel(), horizontal_faces[:, column].ravel()])

    # -- collisions -------------------------------------------------------------------------
    def boxes_near(self, x: np.ndarray, y: np.ndarray, reach: float) -> np.ndarray:
        """The solid blocks that a disc of radius ``reach`` (m) centred at (x[e], y[e]) in maze e
        may overlap: (E, B, 4) boxes ``[xmin, ymin, xmax, ymax]`` (m), the other blocks of the
        neighbourhood as boxes at infinity."""
        bands = 2 * math.ceil(reach / self.cell_size)  # blocks a disc reaches from its centre's
        offsets = np.arange(-bands, bands + 1)
        height, width = self.solid.shape[1:]
        i, j = self.blocks_of(x, y)
        i = np.minimum(np.maximum(i[:, None, None] + offsets[:, None], 0), height - 1)  # (E, n, 1)
        j = np.minimum(np.maximum(j[:, None, None] + offsets, 0), width - 1)  # (E, 1, n)
        shape = (len(x), len(offsets), len(offsets))
        boxes = np.stack(
            [np.broadcast_to(bound, shape) for bound in (self.xs[j], self.ys[i], self.xs[j + 1], self.ys[i + 1])],
            axis=-1,
        ).reshape(len(x), -1, 4)
        solid = self.solid[np.arange(len(x))[:, None, None], i, j].reshape(len(x), -1)
        return np.where(solid[..., None], boxes, np.inf)


def push_out(x: np.ndarray, y: np.ndarray, radius: float, boxes: np.ndarray, iterations: int = 3) -> np.ndarray:
    """Move discs of ``radius`` (m) centred at (x[e], y[e]) (E,) (in place) out of the ``boxes``
    (E, B, 4) they overlap (``MazeGrids.boxes_near``), the deepest overlap first (a corner takes a
    second pass); return (E,) bool, whether each disc overlapped one."""
    touched = np.zeros(len(x), dtype=bool)
    rows = np.arange(len(x))
    low_x, low_y, high_x, high_y = np.moveaxis(boxes, -1, 0)
    for _ in range(iterations):
        gap_x = x[:, None] - np.minimum(np.maximum(x[:, None], low_x), high_x)  # from each box's nearest point
        gap_y = y[:, None] - np.minimum(np.maximum(y[:, None], low_y), high_y)
        squared = gap_x**2 + gap_y**2  # inf for the boxes at infinity
        nearest = np.argmin(squared, axis=1)
        overlap = squared[rows, nearest] < radius**2
        if not overlap.any():
            break
        touched |= overlap
        hit, nearest = rows[overlap], nearest[overlap]
        gap = np.maximum(np.sqrt(squared[hit, nearest]), 1e-12)
        scale = (radius - gap) / gap
        x[hit] += gap_x[hit, nearest] * scale
        y[hit] += gap_y[hit, nearest] * scale
    return touched


def _band(coordinate: np.ndarray, cell_size: float, thickness: float) -> np.ndarray:
    """Block band index along one axis of the points at ``coordinate`` (m): even bands hold walls
    (``k s ± t/2``), odd bands cell interiors."""
    k = np.floor(coordinate / cell_size)
    offset = coordinate - k * cell_size
    return (2 * k + 1 + (offset > cell_size - thickness / 2) - (offset < thickness / 2)).astype(np.int64)
