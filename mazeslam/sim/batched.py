"""Batched maze physics: many robots in many mazes of one shape, stepped together in numpy.

The mazes are held as their solid-block grids (``walls.solid_blocks``): E grids of (2R+1, 2C+1)
blocks sharing the block edges ``xs`` (2C+2,) and ``ys`` (2R+2,), metres. On them:

* ``MazeGrids.cast_edges``: one ray cast for every robot's beams. A ray can only enter a
  solid block where it enters a wall band (cell interiors are free), and its entries into the bands
  along each axis are evenly spaced along it. Most rays meet a wall of their sensor's cell or of
  the neighbour cell they enter through an open side: those are settled from their first crossings
  and per-cell tables made when a maze is set (``MazeGrids.face_tables``); the others look at a
  few crossings per pass, in numpy arrays, until each has met a wall or passed ``max_range``
  (``_BandCrossings``).
  Exact for the maze's axis-aligned thick walls, and cheap, since a ray in a maze meets a wall
  within few cells.
* ``slide``: a robot disc driven step by step and pushed out of the solid blocks it overlaps,
  along the shortest way out, as ``World`` does with pymunk's contacts: a disc slides along a wall
  it drives against and never passes through one (a step moves it much less than its radius).
* ``MazeGrids.edge_bins``: where each beam landed, as a bin of ``spacing`` metres on a wall face, to
  count the wall surface seen.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from mazeslam.sim.maze import Maze
from mazeslam.sim.walls import block_edges, solid_blocks

#: Smallest |direction component| of a ray the cast divides by; a smaller one counts as this (the
#: ray then never reaches the next edge along that axis within any range).
TINY_COMPONENT = 1e-12
#: Band crossings per axis ``MazeGrids.cast_edges`` looks at per pass, for the rays not settled by
#: the cell tables (5: one pass for nearly all of them in a maze of 0.15 m cells and a 0.8 m laser,
#: measured faster than 4 or 6).
LOOKAHEAD = 5
#: Relative error allowed to the float32 distances of ``_BandCrossings`` (float32 rounding is 6e-8).
FLOAT32_SLACK = 1e-6
#: Per lane of ``_BandCrossings.hits``: its index, and ``LOOKAHEAD`` less it (the first solid
#: lane has the largest among the solid ones).
_LANES = np.arange(LOOKAHEAD, dtype=np.int32)[:, None]
_COUNTDOWN = np.arange(LOOKAHEAD, 0, -1, dtype=np.uint8)[:, None]


@dataclass
class MazeGrids:
    """The solid-block grids of E mazes with the same rows, columns, cell size and wall thickness.

    Attributes:
        solid: (E, 2R+1, 2C+1) bool, block [e, i, j] of maze e (i along y, j along x) is solid.
        xs: (2C+2,) block edges along x, metres; ``ys``: (2R+2,) along y.
        cell_size, thickness: metres.
        edges: ``xs`` then ``ys``.
        face_tables: (E * cells + 1) tables of 8 ray codes by 3 cases, int32, per cell of each maze
            (``_set_face_tables``): the wall face a ray leaving that cell meets there or in the
            neighbour cell. Kept up to date by ``set``: change a maze through it, not ``solid``.
        cells: cells per maze.
    """

    solid: np.ndarray
    xs: np.ndarray
    ys: np.ndarray
    cell_size: float
    thickness: float
    edges: np.ndarray = field(init=False, repr=False)

    code_offsets: np.ndarray = field(init=False, repr=False)
    last_block: np.ndarray = field(init=False, repr=False)
    flat_strides: np.ndarray = field(init=False, repr=False)
    face_tables: np.ndarray = field(init=False, repr=False)
    cells: int = field(init=False, repr=False)

    def __post_init__(self):
        self.edges = np.concatenate([self.xs, self.ys])
        self.code_offsets = _code_offsets(self.solid.shape[2])
        self.last_block = np.array(self.solid.shape[1:])[:, None] - 1  # (2, 1) along y, along x
        self.flat_strides = np.array([[1], [self.solid.shape[2]]], dtype=np.int32)  # (2, 1) along x, y
        count, height, width = self.solid.shape
        self.cells = (height // 2) * (width // 2)  # per maze
        self.face_tables = np.full((count * self.cells + 1) * _TABLE_ENTRIES, -1, dtype=np.int32)
        for env in range(count):
            self._set_face_tables(env)

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
        self._set_face_tables(env)

    def _set_face_tables(self, env: int) -> None:
        """``face_tables`` of maze ``env``'s cells: per cell (row-major), ray code ``4 across_x + 2
        up_y + up_x`` (a ray leaving the cell first across x, else y, moving up or down each axis)
        and case (0: it next meets the neighbour cell's far wall, 1: its wall along the other axis,
        2: the post at the gap's end), the block edge (an index into ``edges``) of the face it
        meets: the cell's own if solid, else the one of the case if solid, else -1. One more
        table, the last, is -1 throughout (for a sensor in a wall band)."""
        height, width = self.solid.shape[1:]
        row, col = np.divmod(np.arange(self.cells), width // 2)
        i, j = 2 * row + 1, 2 * col + 1
        block = env * (height * width) + i * width + j
        # Per ray code: the block beside the cell the ray leaves it through; the post at that gap's
        # end (+1 along the axis crossed, a, +1 along the other, b), the neighbour cell's wall
        # along b (+2 along a, +1 along b) and its far wall along a (+3 along a), in blocks.
        solid = self.solid.take(block[:, None, None] + self.code_offsets, mode="clip")  # (cells, 4, 8)
        edges = np.where(_CODE_EDGE_X, j[:, None, None], i[:, None, None] + len(self.xs)) + _CODE_EDGE_STEP
        faces = np.where(solid[:, _CASE_BLOCK], edges[:, _CASE_FACE], -1)  # (cells, 3, 8) per case
        tables = np.where(solid[:, :1], edges[:, :1], faces).transpose(0, 2, 1)  # (cells, 8, 3)
        size = self.cells * _TABLE_ENTRIES
        self.face_tables[env * size : (env + 1) * size] = tables.ravel()

    def blocks_of(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Block indices (i, j) of the points (x, y) (metres), each clipped to the grid."""
        points = np.empty((2, len(x)))
        points[0], points[1] = y, x
        bands = _band(points, self.cell_size, self.thickness)
        np.maximum(bands, 0, out=bands)
        i, j = np.minimum(bands, self.last_block, out=bands)
        return i, j

    # -- ray casting ------------------------------------------------------------------------
    def cast_edges(
        self,
        envs: np.ndarray,
        x: np.ndarray,
        y: np.ndarray,
        heading: np.ndarray,
        bearings: np.ndarray,
        max_range: float,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Cast beams from K sensors, sensor k at (x[k], y[k]) (m) facing ``heading[k]`` (rad) in maze
        ``envs[k]``, along ``bearings`` (N,) (rad, sensor frame). Every sensor must stand in free space.

        Returns ``(distances, edges, along)``, all (K, N): metres to the first wall (``inf`` where
        none lies within ``max_range``); the block edge of the wall face hit, an index into
        ``edges`` (``xs`` then ``ys``: a vertical face, then a horizontal one); and where along that
        face, metres (y on a vertical face, x on a horizontal one). Edges and ``along`` are
        meaningless where the distance is inf.

        A ray enters a solid block only where it enters a wall band (cell interiors are free), so
        only its crossings into the bands ``k s -+ t/2`` are looked at. First, from its first
        crossing on each axis and one lookup in its cell's table (``MazeGrids.face_tables``), a ray that
        leaves its sensor's cell through a wall (about half), or through the open side into the
        neighbour cell and then meets the post at the gap's end, the neighbour's side wall or its
        far wall (about a third); then the others' crossings, ``LOOKAHEAD`` per axis at a time
        (``_BandCrossings``). Which face a ray meets is decided in float32 (each ray alike,
        whatever else is cast with it); its distance is then measured exactly to that face, in
        float64. A direction component under ``TINY_COMPONENT`` counts as that small.
        """
        count, beams = len(envs), len(bearings)
        work = self._workspace(count, beams)
        direction = _directions(heading, bearings, work.direction).reshape(2, -1)  # (2, R) float64, R = K N
        sensors = _Sensors(self, envs, x, y)
        up = direction > 0
        inverse = np.abs(direction, out=work.inverse, casting="same_kind")
        with np.errstate(divide="ignore"):  # a component of exactly 0 (a ray along an axis) gives inf, capped next
            np.divide(1, inverse, out=inverse)  # (2, R) m along the ray per m along each axis
        np.minimum(inverse, np.float32(1 / TINY_COMPONENT), out=inverse)
        # The sensor's ahead for each ray's sense, picked bit by bit (the float32 patterns of ahead
        # down, xor ahead up where up): (2, R) m along each axis to the first band crossing.
        first, picked = work.first, work.first.view(np.int32).reshape(2, count, beams)
        np.subtract(0, up.view(np.uint8), dtype=np.int32, out=work.first.view(np.int32))  # -1 where up
        np.bitwise_and(picked, sensors.ahead_flip, out=picked)
        np.bitwise_xor(picked, sensors.ahead_down, out=picked)
        first *= inverse  # (2, R) m along the ray to the first band crossing along each axis
        across_x = first[0] <= first[1]
        # Leaving the own cell across axis a (the nearer first crossing): through its wall there if
        # that block is solid; else, through the open side into the neighbour cell, the post at the
        # gap's end if the ray enters b's band within the gap, the neighbour's wall along b if it
        # enters that band before the far wall, else the far wall (case 2, 1, 0): one table entry
        # per sensor, ray code and case, the face's block edge or -1 (not settled here).
        near, far = np.minimum(first[0], first[1]), np.maximum(first[0], first[1])
        inverse_a = np.where(across_x, inverse[0], inverse[1])
        case = far < inverse_a * np.float32(self.thickness) + near  # b entered within the gap (post)
        case = case.view(np.uint8) + (far <= inverse_a * np.float32(self.cell_size) + near)  # + before the far wall
        ray_code = across_x.view(np.uint8) << 2 | up[1].view(np.uint8) << 1 | up[0].view(np.uint8)
        ray_code *= 3
        ray_code += case
        code = work.code
        np.copyto(code.reshape(count, beams), sensors.table[:, None])
        code += ray_code
        edge = self.face_tables.take(code)
        missed = np.zeros(count * beams, dtype=bool)
        rest = (edge < 0).nonzero()[0]
        if len(rest):
            crossings = _BandCrossings(self, sensors, rest, beams, direction, up, inverse, first, across_x)
            _, rest_edge, rest_missed = crossings.hits(max_range)
            edge[rest], missed[rest] = rest_edge, rest_missed
        return self._measure(sensors, direction, edge, missed, max_range, (count, beams))

    def _workspace(self, count: int, beams: int) -> _Workspace:
        """Arrays a cast of ``count`` sensors by ``beams`` beams reuses (not returned)."""
        work = getattr(self, "_work", None)
        if work is None or work.code.shape != (count * beams,):
            work = self._work = _Workspace(count, beams)
        return work

    def _measure(self, sensors, direction, edge, missed, max_range, shape):
        """``cast_edges``'s ``(distances, edges, along)`` of the rays along ``direction`` (2, R) that meet
        the block edge ``edge`` (R,) (an index into ``xs`` then ``ys``: a vertical face first); none
        where ``missed``."""
        work = self._workspace(*shape)
        rays = len(edge)
        # Per ray, the index into (2, R) arrays of its component along the face's normal (x for a
        # vertical face) and of the one along the face.
        normal = np.multiply(edge >= len(self.xs), rays, out=work.normal_index, casting="unsafe")
        normal += work.rays
        sideways = np.subtract(work.both_axes, normal, out=work.sideways_index)
        origins = np.repeat(sensors.origin, shape[1], axis=1).ravel()  # (2 R,) x, y of each ray's sensor
        components = direction.ravel()
        exact = self.edges.take(edge, mode="clip")
        exact -= origins.take(normal)
        exact /= components.take(normal)  # m along the ray to the face
        along = components.take(sideways)
        along *= exact
        along += origins.take(sideways)
        missed |= exact > max_range
        exact[missed] = np.inf
        return exact.reshape(shape), edge.reshape(shape), along.reshape(shape)

    # -- wall faces seen --------------------------------------------------------------------
    def bin_counts(self, spacing: float) -> tuple[int, int]:
        """Bins of ``spacing`` metres along a vertical and along a horizontal block edge."""
        return (math.ceil((self.ys[-1] - self.ys[0]) / spacing), math.ceil((self.xs[-1] - self.xs[0]) / spacing))

    def bin_total(self, spacing: float) -> int:
        """How many ``edge_bins`` there are."""
        along_y, along_x = self.bin_counts(spacing)
        return len(self.xs) * along_y + len(self.ys) * along_x

    def bin_points(self, bins: np.ndarray, spacing: float) -> np.ndarray:
        """(K, 2) centres (m) of ``edge_bins`` ``bins`` (K,)."""
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

    def edge_bins(self, edge: np.ndarray, along: np.ndarray, spacing: float) -> np.ndarray:
        """Bin index (same shape as ``edge``) of the wall points ``along`` (m) block edges ``edge`` (as
        ``cast_edges`` gives them): bins of ``spacing`` metres along each block edge, vertical edges
        first, then horizontal ones."""
        base, low, top = self._bin_tables(spacing)
        step = np.subtract(along, low[0] if self._bins_square else low.take(edge, mode="clip"))
        step /= spacing
        bins = step.astype(np.int64)
        np.maximum(bins, 0, out=bins)
        if self._bins_square:  # every block edge has as many bins, and they start alike
            np.minimum(bins, top[0], out=bins)
            bins += edge * (top[0] + 1)
        else:
            np.minimum(bins, top.take(edge, mode="clip"), out=bins)
            bins += base.take(edge, mode="clip")
        return bins

    def _bin_tables(self, spacing: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Per block edge (``edges``): its first ``edge_bins`` bin, where its bins start (m) and its
        last bin's step."""
        if getattr(self, "_bins_spacing", None) != spacing:
            along_y, along_x = self.bin_counts(spacing)
            vertical = np.arange(len(self.edges)) < len(self.xs)
            base = np.where(vertical, np.arange(len(self.edges)) * along_y, 0)
            base[~vertical] = len(self.xs) * along_y + np.arange(len(self.ys)) * along_x
            low = np.where(vertical, self.ys[0], self.xs[0])
            top = np.where(vertical, along_y, along_x) - 1
            self._bins_spacing, self._bins = spacing, (base, low, top)
            self._bins_square = along_x == along_y and self.xs[0] == self.ys[0]  # base = edge * bins per edge
        return self._bins

    def wall_bins(self, env: int, spacing: float) -> np.ndarray:
        """Which bins (``edge_bins``) of maze ``env`` have their centre on a wall face: (bins,) bool."""
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
        may overlap: (4, B, E) boxes' ``xmin, ymin, xmax, ymax`` (m), the other blocks of the
        neighbourhood as boxes at infinity."""
        # Blocks a disc reaches from its centre's: the next band on each side while it reaches less
        # than a cell's free width (solid blocks lie in wall bands only, one cell apart).
        bands = 1 if reach < self.cell_size - self.thickness else 2 * math.ceil(reach / self.cell_size)
        offsets = np.arange(-bands, bands + 1)[:, None]
        height, width = self.solid.shape[1:]
        i, j = self.blocks_of(x, y)
        i = np.minimum(np.maximum(i + offsets, 0), height - 1)  # (n, E)
        j = np.minimum(np.maximum(j + offsets, 0), width - 1)  # (n, E)
        size, count = i.shape
        block = np.arange(count) * (height * width) + (i * width)[:, None] + j  # (n, n, E): along y, x
        bounds = np.empty((4, size, size, count))
        bounds[0], bounds[2] = self.xs.take(j), self.xs.take(j + 1)
        bounds[1], bounds[3] = self.ys.take(i)[:, None], self.ys.take(i + 1)[:, None]
        np.copyto(bounds, np.inf, where=~self.solid.take(block))
        return bounds.reshape(4, -1, count)


def slide(
    x: float, y: float, moves: list[list[float]], radius: float, boxes: list[list[float]], iterations: int = 3
) -> tuple[float, float, bool]:
    """Drive a disc of ``radius`` (m) centred at (x, y) (m) by each of ``moves`` [(dx, dy), ...] (m)
    in turn, pushing it after each out of the ``boxes`` [[xmin, ymin, xmax, ymax], ...] (m) it
    overlaps (``MazeGrids.boxes_near``'s solid ones), as ``World`` does with pymunk's contacts;
    return the final centre and whether it overlapped a box.

    Each push goes along the shortest way out of the deepest overlap; a disc that overlapped two
    boxes (a corner) takes another pass, up to ``iterations``; one that overlapped one is out of
    every box once pushed out of it, as it moves much less than a corridor's free width (boxes
    across a corridor are that far apart), so it slides along a wall it drives against and never
    passes through one. Plain Python floats: a robot in contact has a few boxes near it, and
    numpy's per-call cost would outweigh the arithmetic."""
    reach, touched = radius * radius, False
    for dx, dy in moves:
        x += dx
        y += dy
        for _ in range(iterations):
            deepest, overlapping, gap_x, gap_y = math.inf, 0, 0.0, 0.0
            for xmin, ymin, xmax, ymax in boxes:  # the gap from each box's nearest point
                gx = x - (xmin if x < xmin else xmax if x > xmax else x)
                gy = y - (ymin if y < ymin else ymax if y > ymax else y)
                squared = gx * gx + gy * gy
                if squared < reach:
                    overlapping += 1
                if squared < deepest:
                    deepest, gap_x, gap_y = squared, gx, gy
            if not overlapping:
                break
            touched = True
            distance = max(math.sqrt(deepest), 1e-12)
            scale = (radius - distance) / distance
            x += gap_x * scale
            y += gap_y * scale
            if overlapping == 1:
                break
    return x, y, touched


class _Workspace:
    """``MazeGrids.cast_edges``' own arrays for K sensors by N beams, kept from cast to cast."""

    def __init__(self, count: int, beams: int):
        self.direction = np.empty((2, count, beams))
        self.inverse = np.empty((2, count * beams), dtype=np.float32)
        self.first = np.empty((2, count * beams), dtype=np.float32)
        self.code = np.empty(count * beams, dtype=np.int32)
        self.rays = np.arange(count * beams, dtype=np.int32)
        self.both_axes = count * beams + 2 * self.rays  # an index into (2, R) arrays plus its other axis'
        self.normal_index, self.sideways_index = np.empty((2, count * beams), dtype=np.int32)


class _Sensors:
    """Per sensor of one ``MazeGrids.cast_edges``: where it stands and what its rays first meet.

    Attributes:
        origin: (2, K) x, y (m).
        ahead: (2, K, 2) float32, per axis and sense (down, up): metres along that axis to the
            first wall band entered (that of line ``line``: its near face at ``line s -+ t/2``).
        ahead_down, ahead_flip: (2, K, 1) int32, the bit patterns of ahead down, and of ahead
            down xor ahead up.
        line: (2, K, 2) that line's index.
        table: (K,) where the sensor's cell's table starts in ``MazeGrids.face_tables`` (the
            last, -1 throughout, for a sensor in a wall band).
    """

    def __init__(self, grids: MazeGrids, envs: np.ndarray, x: np.ndarray, y: np.ndarray):
        s, half = grids.cell_size, grids.thickness / 2
        height, width = grids.solid.shape[1:]
        self.origin = np.empty((2, len(x)))
        self.origin[0], self.origin[1] = x, y
        q = _SENSE * self.origin[..., None] + half  # (2, K, 2): the coordinate along each sense, + t/2
        lines = np.floor(q / s) + 1
        self.ahead = (lines * s - q).astype(np.float32)
        bits = self.ahead.view(np.int32)
        self.ahead_down, self.ahead_flip = bits[..., :1], bits[..., 1:] ^ bits[..., :1]  # (2, K, 1) each
        self.line = (_SENSE * lines).astype(np.int64)
        # The block (j, i) a sensor stands in is line up - line down along each axis, in a cell's
        # interior where those add up to 1 (in a wall band, 2).
        j, i = (lines[..., 1] - lines[..., 0]).astype(np.int64)
        inside = (lines[0, :, 0] + lines[0, :, 1] == 1) & (lines[1, :, 0] + lines[1, :, 1] == 1)  # (K,)
        cell = envs * grids.cells + (i >> 1) * (width // 2) + (j >> 1)
        self.table = np.where(inside, cell, len(grids.face_tables) // _TABLE_ENTRIES - 1) * _TABLE_ENTRIES
        self.inside, self.envs = inside, envs


#: The two senses along an axis: down, up; and whether down.
_SENSE = np.array([-1, 1])
_DOWN = _SENSE < 0
#: Per own-cell ray code ``4 across_x + 2 up_y + up_x`` (``_Sensors``): whether across x, and
#: whether moving up along the axis crossed.
_X_CODES = np.array([False] * 4 + [True] * 4)
_UP_CODES = np.array([0, 0, 1, 1, 0, 1, 0, 1])
_CODE = np.arange(8)
_UP_B = np.where(_X_CODES, _CODE // 2 % 2, _CODE % 2)  # whether moving up along the other axis
#: Per ray code, the block edges of ``_Sensors``' own, side and far faces: along x (else y), and
#: the step from the own cell's block index.
_CODE_EDGE_X = np.stack([_X_CODES, ~_X_CODES, _X_CODES])
_CODE_EDGE_STEP = np.stack([_UP_CODES, _UP_B, _UP_CODES + 2 * (2 * _UP_CODES - 1)])
#: Per case of ``MazeGrids.face_tables`` (far, side, post): its block in ``_code_offsets`` and its
#: face; entries per cell (ray codes by cases).
_CASE_BLOCK, _CASE_FACE = [3, 2, 1], [2, 1, 1]
_TABLE_ENTRIES = 8 * 3


def _code_offsets(width: int) -> np.ndarray:
    """(4, 8) flat block offsets per ray code from a cell's block: beside it, the post, the side
    wall and the far wall (``_Sensors``), for grids ``width`` blocks wide."""
    along_a = np.where(_X_CODES, 1, width) * (2 * _UP_CODES - 1)
    along_b = np.where(_X_CODES, width, 1) * (2 * _UP_B - 1)
    return np.stack([along_a, along_a + along_b, 2 * along_a + along_b, 3 * along_a])


class _BandCrossings:
    """The rays of one ``MazeGrids.cast_edges`` not settled by the cell tables, and their crossings
    into wall bands.

    Along each axis a ray enters the wall band of grid line k (``k s -+ t/2``) at
    ``t = first + n * spacing`` (m along the ray), n = 0, 1, ... from its first band on; there it
    enters the block of band 2k along that axis and, across it, of the band the other coordinate
    lies in. The first solid block entered on either axis is the hit (x first on a tie), certain once
    no crossing not yet looked at lies nearer. The distances here are float32 (to about 1e-7 m),
    enough to tell which face a ray meets (``MazeGrids.cast_edges`` then measures the distance to it
    exactly); every ray's are computed alike (the same operations whatever else is cast with it),
    so a ray's hit does not depend on the others cast with it.

    Per axis a (0: x, 1: y) and ray, (2, M) arrays: ``first`` and ``spacing`` (m, float32),
    ``rate`` (the other coordinate's change in cells per m, float32), ``n0`` (the first crossing
    not known free), ``t0`` and ``u0`` (crossing n0's distance, m, and other coordinate, cells,
    shifted by t/2), ``base`` and ``stride`` (int32: the flat index into ``solid`` of crossing n0 +
    l's block is ``base + l * stride + across * band``, ``across`` the flat stride of the other
    axis, 2C+1 or 1, and ``band = floor(u) + floor(u - t/s)`` for that crossing's u), ``steps`` and
    ``edge0`` (crossing n's block edge is ``edge0 + n * steps``). A crossing past the maze's outer
    wall may index any block: it lies beyond a solid crossing of the same ray (the outer wall is
    closed), and is never taken for the hit.
    """

    def __init__(self, grids, sensors, rays, beams, direction, up, inverse, first, across_x):
        """The rays ``rays`` (M,) (indices into the cast's R = K N rays, ``beams`` per sensor), with
        the cast's (2, R) ``direction``, ``up`` (whether moving up each axis), ``inverse`` (1 /
        |direction|, float32), ``first`` (first crossings, m, float32) and (R,) ``across_x``
        (whether the first crossing along x is the nearer)."""
        s, half = grids.cell_size, grids.thickness / 2
        height, width = grids.solid.shape[1:]
        self.solid = grids.solid.view(np.uint8).ravel()
        self.thin = np.float32(grids.thickness / s)  # share of a cell's width a wall band takes
        self.across = grids.flat_strides[::-1, :, None]  # (2, 1, 1): the other axis's
        sensor = rays // beams
        up = up.take(rays, axis=1)
        count = len(sensors.envs)
        key = up + 2 * sensor  # (2, M): per axis, the sensor's sense entry
        key[1] += 2 * count
        self.first = first.take(rays, axis=1)
        self.spacing = inverse.take(rays, axis=1)
        self.spacing *= np.float32(s)
        rate = direction.take(rays, axis=1)[::-1].astype(np.float32)
        rate *= np.float32(1 / s)
        offset = ((sensors.origin[::-1] + half) / s).astype(np.float32).take(sensor, axis=1)
        unit = grids.flat_strides  # (2, 1) flat stride of a block along x, along y
        # Per axis, sensor and sense: crossing 0's flat block index less its ``across * band``
        # (band + 1 across), and the block edge of that band's near face.
        tables = np.empty((2, 2, count, 2), dtype=np.int32)
        np.multiply(sensors.line, 2 * unit[:, :, None], out=tables[0], casting="same_kind")
        tables[0] += (sensors.envs * (height * width))[:, None]
        tables[0] += unit[::-1, :, None]
        np.multiply(sensors.line, 2, out=tables[1], casting="same_kind")
        tables[1] += _DOWN
        tables[1, 1] += len(grids.xs)
        start, self.edge0 = tables.reshape(2, -1).take(key.ravel(), axis=1).reshape(2, 2, -1)  # (2, M) each
        # Crossing 0 on the axis a ray left its cell across is free (the cell's open side).
        inside = sensors.inside[sensor]
        across = across_x[rays]
        n0 = np.empty((2, len(rays)), dtype=np.int32)
        n0[0], n0[1] = inside & across, inside & ~across
        self.steps = np.multiply(up, 4, dtype=np.int32)
        self.steps -= 2  # block edges a crossing: 2, down or up
        self.stride = self.steps * unit  # flat index steps a crossing
        self.rate = rate
        # Per pass: crossing n0 + l (l < LOOKAHEAD) of each axis at t0 + l spacing (m), with the
        # other coordinate u0 + l du (cells) and block index base + l stride + across band.
        self.n0 = n0
        self.t0 = n0.astype(np.float32) * self.spacing
        self.t0 += self.first
        self.u0 = self.t0 * rate
        self.u0 += offset
        self.base = n0 * self.stride
        self.base += start

    def hits(self, max_range: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(M,) arrays: whether each ray's hit is on a vertical face, the block edge of the face
        (an index into ``MazeGrids.edges``), whether it has none within ``max_range``."""
        lanes, last = _LANES, np.float32(LOOKAHEAD - 1)
        active = None  # the rays looked at in this pass (None: all)
        t0, u0, base, spacing, du, stride, n0 = (
            self.t0,
            self.u0,
            self.base,
            self.spacing,
            self.spacing * self.rate,
            self.stride,
            self.n0,
        )
        while True:
            u = lanes * du[:, None]
            u += u0[:, None]  # (2, L, M') cells
            band = np.floor(u)
            u -= self.thin
            band += np.floor(u, out=u)
            with np.errstate(invalid="ignore"):  # rays along an axis: far crossings, any block
                index = band.astype(np.int32)
            index *= self.across
            index += lanes * stride[:, None]
            index += base[:, None]
            solid = self.solid.take(index, mode="clip")  # (2, L, M') 0 or 1
            solid *= _COUNTDOWN
            first_solid = solid.max(axis=1)  # (2, M') L - the first solid crossing's lane, 0: none
            lane = np.subtract(LOOKAHEAD, first_solid, dtype=np.int32)
            found = lane.astype(np.float32)
            found *= spacing
            found += t0  # (2, M') m, as lane * spacing + t0 for every lane
            found = np.where(first_solid > 0, found, np.float32(np.inf))
            lane += n0
            if active is None:  # per axis, the nearest solid crossing (m) and its n
                best, crossing = found, lane
            else:
                nearer = found < best[:, active]
                best[:, active] = np.where(nearer, found, best[:, active])
                crossing[:, active] = np.where(nearer, lane, crossing[:, active])
            limit = (last * spacing + t0 + spacing).min(axis=0)  # nearest crossing not looked at
            # Done once a hit is nearer, or past the range; a NaN ray (a NaN pose) never gets
            # nearer, so it counts as done too, and is left to ``missed`` (never a hang).
            done = (found.min(axis=0) < limit) | ~(limit <= max_range)
            if done.all():
                break
            keep = ~done
            active = keep.nonzero()[0] if active is None else active[keep]
            t0, u0, base, spacing, du, stride, n0 = (
                part.compress(keep, axis=-1) for part in (t0, u0, base, spacing, du, stride, n0)
            )
            t0 += LOOKAHEAD * spacing
            u0 += LOOKAHEAD * du
            base += LOOKAHEAD * stride
            n0 = n0 + LOOKAHEAD
        across_x = best[0] <= best[1]
        crossing *= self.steps
        crossing += self.edge0
        missed = ~(np.minimum(best[0], best[1]) <= max_range * (1 + FLOAT32_SLACK))
        return across_x, np.where(across_x, crossing[0], crossing[1]), missed


def _directions(heading: np.ndarray, bearings: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """(2, K, N) world unit vectors (x, y) of the beams ``bearings`` (N,) (rad) of sensors facing
    ``heading`` (K,) (rad)."""
    cos_h, sin_h = np.cos(heading)[:, None], np.sin(heading)[:, None]
    cos_b, sin_b = np.cos(bearings), np.sin(bearings)
    direction = np.empty((2, len(heading), len(bearings))) if out is None else out
    np.multiply(cos_h, cos_b, out=direction[0])
    direction[0] -= sin_h * sin_b
    np.multiply(sin_h, cos_b, out=direction[1])
    direction[1] += cos_h * sin_b
    return direction


def _band(coordinate: np.ndarray, cell_size: float, thickness: float) -> np.ndarray:
    """Block band index along one axis of the points at ``coordinate`` (m): even bands hold walls
    (``k s ± t/2``), odd bands cell interiors."""
    k = np.floor(coordinate / cell_size)
    offset = coordinate - k * cell_size
    return (2 * k + 1 + (offset > cell_size - thickness / 2) - (offset < thickness / 2)).astype(np.int64)
