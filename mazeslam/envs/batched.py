"""Batched maze physics: many robots in many mazes of one shape, stepped together in numpy.

The mazes are held as their solid-block grids (``walls.solid_blocks``): E grids of (2R+1, 2C+1)
blocks sharing the block edges ``xs`` (2C+2,) and ``ys`` (2R+2,), metres. On them:

* ``MazeGrids.cast``: one ray cast for every robot's beams. A ray can only enter a solid block
  where it enters a wall band (cell interiors are free), and its entries into the bands along each
  axis are evenly spaced along it: all rays look at a few of those crossings per pass, in numpy
  arrays, until each has met a wall or passed ``max_range`` (``_BandCrossings``); exact for the
  maze's axis-aligned thick walls, and cheap, since a ray in a maze meets a wall within few cells.
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
#: ``MazeGrids.cast`` looks at every band crossing within range in one pass when the rays times
#: those crossings are at most this many (small casts: fewer passes), else at three per pass.
LOOK_ALL_BELOW = 16384
#: Relative error allowed to the float32 distances of ``_BandCrossings`` (float32 rounding is 6e-8).
FLOAT32_SLACK = 1e-6


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
        ``envs[k]``, along ``bearings`` (N,) (rad, sensor frame). Every sensor must stand in free space.

        Returns ``(distances, faces, along)``, all (K, N): metres to the first wall (``inf`` where
        none lies within ``max_range``); the wall face hit: ``f >= 0`` the vertical face on
        ``x = xs[f]``, ``f < 0`` the horizontal face on ``y = ys[-1 - f]``; and where along that
        face, metres (y on a vertical face, x on a horizontal one). Faces and ``along`` are
        meaningless where the distance is inf.

        A ray enters a solid block only where it enters a wall band (cell interiors are free), so
        only its crossings into the bands ``k s -+ t/2`` are looked at, a few per axis at a time
        (``lookahead``) for all rays at once (see ``_BandCrossings``); with many rays, those that
        leave their sensor's cell through a wall are settled first (``_BandCrossings.own_cell``).
        """
        count, beams = len(envs), len(bearings)
        origin = np.stack([x, y])[:, :, None]  # (2, K, 1), m
        direction = _directions(heading, bearings)  # (2, K, N)
        crossings = _BandCrossings(self, origin, direction, envs)
        distances = np.full(count * beams, np.inf)
        across_x = np.zeros(count * beams, dtype=bool)
        active = np.arange(count * beams)
        if self._lookahead(len(active), max_range) < self._crossings_in_range(max_range):
            hit, hit_x, done = crossings.own_cell(self, envs, origin)  # many rays: the easy ones first
            limit, lookahead = hit, 0  # nothing looked at yet
        else:  # few: all at once
            lookahead = self._crossings_in_range(max_range)
            hit, hit_x, done, limit = crossings.look(lookahead, max_range)
        while True:
            settled = active[done]
            distances[settled], across_x[settled] = hit[done], hit_x[done]
            if done.all():
                break
            active = active[~done]
            crossings.advance(~done, limit, lookahead)
            lookahead = self._lookahead(len(active), max_range)
            hit, hit_x, done, limit = crossings.look(lookahead, max_range)
        distances[distances > max_range * (1 + FLOAT32_SLACK)] = np.inf  # none in range
        shape = (count, beams)
        faces, along, distances = self._faces(origin, direction, distances.reshape(shape), across_x.reshape(shape))
        distances[distances > max_range] = np.inf
        return distances, faces, along

    def _lookahead(self, rays: int, max_range: float) -> int:
        """Band crossings per axis looked at per ray in one pass: all within ``max_range`` when few
        rays remain (one pass, no bookkeeping), else three (most rays meet a wall within three
        cells; measured fastest with 64 and 256 robots)."""
        within_range = self._crossings_in_range(max_range)
        return within_range if rays * within_range <= LOOK_ALL_BELOW else min(3, within_range)

    def _crossings_in_range(self, max_range: float) -> int:
        """The most band crossings along one axis within ``max_range`` of any point."""
        return math.floor(max_range / self.cell_size) + 1

    def _faces(self, origin, direction, distances, across_x):
        """The faces hit (as ``cast`` returns them) by the rays from ``origin`` (2, K, 1) (m) along
        ``direction`` (2, K, N) at about ``distances`` (K, N) (m, inf: none), through a vertical
        face where ``across_x`` (K, N): ``(faces, along, distances)``, all (K, N), the distances
        now measured exactly to the faces' block edges."""
        s, half = self.cell_size, self.thickness / 2
        origin, other = (np.where(across_x, origin[k], origin[1 - k]) for k in (0, 1))
        normal, sideways = (np.where(across_x, direction[k], direction[1 - k]) for k in (0, 1))
        missed = np.isinf(distances)
        # The face of band k is on k s - t/2 (entered moving up) or k s + t/2 (moving down):
        # block edge 2k or 2k + 1.
        reached = origin + np.where(missed, 0.0, distances) * normal
        edge = 2 * np.rint((reached + np.copysign(half, normal)) / s).astype(np.int64) + (normal < 0)
        edges = np.concatenate([self.xs, self.ys])
        position = edges[np.clip(np.where(across_x, edge, len(self.xs) + edge), 0, len(edges) - 1)]
        exact = (position - origin) / normal
        along = other + exact * sideways
        exact[missed] = np.inf
        return np.where(across_x, edge, -1 - edge), along, exact

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
        may overlap: (4, E, B) boxes' ``xmin, ymin, xmax, ymax`` (m), the other blocks of the
        neighbourhood as boxes at infinity."""
        # Blocks a disc reaches from its centre's: the next band on each side while it reaches less
        # than a cell's free width (solid blocks lie in wall bands only, one cell apart).
        bands = 1 if reach < self.cell_size - self.thickness else 2 * math.ceil(reach / self.cell_size)
        offsets = np.arange(-bands, bands + 1)
        height, width = self.solid.shape[1:]
        i, j = self.blocks_of(x, y)
        i = np.minimum(np.maximum(i[:, None, None] + offsets[:, None], 0), height - 1)  # (E, n, 1)
        j = np.minimum(np.maximum(j[:, None, None] + offsets, 0), width - 1)  # (E, 1, n)
        solid = self.solid[np.arange(len(x))[:, None, None], i, j]
        bounds = (self.xs[j], self.ys[i], self.xs[j + 1], self.ys[i + 1])
        return np.stack([np.where(solid, bound, np.inf) for bound in bounds]).reshape(4, len(x), -1)


def push_out(position: np.ndarray, radius: float, boxes: np.ndarray, iterations: int = 3) -> np.ndarray:
    """Move discs of ``radius`` (m) centred at ``position`` (2, E) (x, y; m; in place) out of the
    ``boxes`` (4, E, B) they overlap (``MazeGrids.boxes_near``), the deepest overlap first; return
    (E,) bool, whether each disc overlapped one. A disc that overlapped two boxes (a corner) takes
    another pass; one that overlapped one is out of every box once pushed out of it, as it moves
    much less than a corridor's free width (boxes across a corridor are that far apart)."""
    touched = np.zeros(position.shape[1], dtype=bool)
    low, high = boxes[:2], boxes[2:]  # (2, E, B) each: x, y
    discs = np.arange(position.shape[1])  # the discs looked at in this pass
    for _ in range(iterations):
        point = position[:, discs, None]
        gap = point - np.minimum(np.maximum(point, low), high)  # from each box's nearest point (inf: none)
        squared = (gap * gap).sum(axis=0)  # (E', B)
        nearest = squared.argmin(axis=1)
        deepest = squared[np.arange(len(discs)), nearest]
        overlap = deepest < radius * radius
        if not overlap.any():
            break
        discs = discs[overlap]
        touched[discs] = True
        distance = np.maximum(np.sqrt(deepest[overlap]), 1e-12)
        position[:, discs] += gap[:, overlap, nearest[overlap]] * ((radius - distance) / distance)
        corner = (squared[overlap] < radius * radius).sum(axis=1) > 1
        if not corner.any():
            break
        discs, low, high = discs[corner], low[:, overlap][:, corner], high[:, overlap][:, corner]
    return touched


class _BandCrossings:
    """The rays of one ``MazeGrids.cast`` still flying, and their next crossings into wall bands.

    Along each axis a ray enters the wall band of grid line k (``k s -+ t/2``) at
    ``t = first + n * spacing`` (m along the ray), n = 0, 1, ... from its next band on; there it
    enters the block of band 2k along that axis and, across it, of the band the other coordinate
    lies in. The first solid block entered on either axis is the hit, certain once no crossing not
    yet looked at lies nearer. The distances here are float32 (to about 1e-7 m), enough to tell
    which face a ray meets (``MazeGrids.cast`` then measures the distance to it exactly).

    Per axis a (0: x, 1: y) and ray, ``floats[:, a]`` (4, 2, R) float32 holds ``first``,
    ``spacing`` (m), ``offset`` and ``rate``; ``ints[:, a]`` (2, 2, R) int32 ``start`` and
    ``stride``: the flat index (into ``solid``) of crossing n's block is ``start + n * stride +
    across * band``, ``across`` the flat stride of the other axis (2C+1 or 1) and ``band =
    floor(u) + floor(u - t/s)`` (+ 1 in ``start``) for ``u = offset + t * rate``, the other
    coordinate at the crossing in cells, shifted by t/2. A crossing past the maze's outer wall
    may index any block: it lies beyond a solid crossing of the same ray (the outer wall is
    closed), and ``look`` never takes it for the hit.
    """

    def __init__(self, grids: MazeGrids, origin: np.ndarray, direction: np.ndarray, envs: np.ndarray):
        """Rays from ``origin`` (2, K, 1) (m) in maze ``envs[k]`` along ``direction`` (2, K, N)."""
        s, half = grids.cell_size, grids.thickness / 2
        height, width = grids.solid.shape[1:]
        self.solid = grids.solid.ravel()
        self.thin = np.float32(grids.thickness / s)  # share of a cell's width a wall band takes
        self.across = np.array([width, 1], dtype=np.int32)[:, None, None]
        up = direction > 0
        inverse = 1 / np.abs(direction)
        # Per sensor, axis and sense (last axis: down, up): q the origin's coordinate + t/2 along
        # the sense, and the first band entered that of line index ``sense * lines`` (its near face
        # at lines * s - t/2, ``ahead`` = lines * s - q metres on along that axis).
        sense = np.array([-1, 1])
        q = sense * origin + half  # (2, K, 2)
        lines = np.floor(q / s) + 1
        ahead = lines * s - q
        unit = np.array([1, width])[:, None, None]  # flat stride of a block along x, along y
        stride = 2 * unit * sense  # (2, 1, 2)
        start = (envs * (height * width))[:, None] + self.across[:, 0][:, :, None] + stride * lines
        rays = direction.shape[1] * direction.shape[2]
        self.floats = np.empty((4, 2, rays), dtype=np.float32)
        floats = self.floats.reshape(4, *direction.shape)
        np.multiply(np.where(up, ahead[..., 1:], ahead[..., :1]), inverse, out=floats[0])  # first
        np.multiply(s, inverse, out=floats[1])  # spacing
        floats[2] = (origin[::-1] + half) / s  # offset
        np.multiply(direction[::-1], 1 / s, out=floats[3])  # rate
        self.ints = np.empty((2, 2, rays), dtype=np.int32)
        ints = self.ints.reshape(2, *direction.shape)
        ints[0] = np.where(up, start[..., 1:], start[..., :1])  # band 2k (+ band 1 across) of line k
        ints[1] = np.where(up, stride[..., 1:], stride[..., :1])

    def look(self, lookahead: int, max_range: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Look at the next ``lookahead`` band crossings per axis of every ray; return (R,) arrays:
        the nearest solid one (m, inf if none), whether it is an x crossing (vertical face),
        whether the ray is done (that hit is certain, or nothing within ``max_range`` is left),
        and the nearest crossing not looked at (m)."""
        first, spacing, offset, rate = (part[:, None] for part in self.floats)  # (2, 1, R)
        start, stride = (part[:, None] for part in self.ints)
        n = np.arange(lookahead, dtype=np.float32)[:, None]  # (L, 1)
        t = first + n * spacing  # (2, L, R), m
        u = offset + t * rate
        band = (np.floor(u) + np.floor(u - self.thin)).astype(np.int32)
        index = start + n.astype(np.int32) * stride + self.across * band
        np.clip(index, 0, len(self.solid) - 1, out=index)
        hits = np.where(self.solid[index], t, np.float32(np.inf)).min(axis=1)  # (2, R)
        hit = hits.min(axis=0)
        limit = (t[:, -1] + spacing[:, 0]).min(axis=0)  # the nearest crossing not looked at
        return hit, hits[0] <= hits[1], (hit <= limit) | (limit > max_range), limit

    def own_cell(self, grids: MazeGrids, envs: np.ndarray, origin: np.ndarray):
        """The rays that leave their sensor's cell through one of its walls, where the sensor stands
        inside a cell (not in an open wall's gap): there the nearer first crossing is the hit, in
        the block beside the cell on that side. Returns (R,) arrays as ``look``: the hit (m), whether
        through a vertical face, whether done (these rays)."""
        i, j = grids.blocks_of(origin[0, :, 0], origin[1, :, 0])  # (K,) the sensors' blocks
        inside = (i % 2 == 1) & (j % 2 == 1)  # a cell's interior, not a wall band
        solid = grids.solid
        # (K, 4): is the block beside the cell solid: left, right, below, above.
        beside = np.column_stack(
            [solid[envs, i, j - 1], solid[envs, i, np.minimum(j + 1, solid.shape[2] - 1)]]
            + [solid[envs, i - 1, j], solid[envs, np.minimum(i + 1, solid.shape[1] - 1), j]]
        )
        first, up = self.floats[0], self.ints[1] > 0  # (2, R): distances, whether moving up x, up y
        across_x = first[0] <= first[1]
        side = np.where(across_x, up[0], 2 + up[1]).reshape(len(envs), -1)  # (K, N)
        done = np.take_along_axis(beside, side, axis=1) & inside[:, None]
        return np.minimum(first[0], first[1]), across_x, done.ravel()

    def advance(self, keep: np.ndarray, limit: np.ndarray, lookahead: int) -> None:
        """Keep the rays where ``keep`` (R,) holds, moved past their crossings nearer than ``limit``
        (m) (``look``ed at with ``lookahead`` and found free; none when 0)."""
        # (np.compress keeps the arrays C-contiguous, unlike a[..., keep].)
        self.floats, self.ints = np.compress(keep, self.floats, axis=-1), np.compress(keep, self.ints, axis=-1)
        if not lookahead:
            return
        first, spacing = self.floats[:2]
        passed = np.floor((limit[keep] - first) / spacing) + 1
        passed = np.minimum(np.maximum(passed, 0), lookahead).astype(np.int32)
        first += passed * spacing
        self.ints[0] += passed * self.ints[1]


def _directions(heading: np.ndarray, bearings: np.ndarray) -> np.ndarray:
    """(2, K, N) world unit vectors (x, y) of the beams ``bearings`` (N,) (rad) of sensors facing
    ``heading`` (K,) (rad); components under ``TINY_COMPONENT`` raised to it."""
    cos_h, sin_h = np.cos(heading)[:, None], np.sin(heading)[:, None]
    cos_b, sin_b = np.cos(bearings), np.sin(bearings)
    direction = np.stack([cos_h * cos_b - sin_h * sin_b, sin_h * cos_b + cos_h * sin_b])
    direction[np.abs(direction) < TINY_COMPONENT] = TINY_COMPONENT
    return direction


def _band(coordinate: np.ndarray, cell_size: float, thickness: float) -> np.ndarray:
    """Block band index along one axis of the points at ``coordinate`` (m): even bands hold walls
    (``k s ± t/2``), odd bands cell interiors."""
    k = np.floor(coordinate / cell_size)
    offset = coordinate - k * cell_size
    return (2 * k + 1 + (offset > cell_size - thickness / 2) - (offset < thickness / 2)).astype(np.int64)
