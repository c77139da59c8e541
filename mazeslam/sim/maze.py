"""Mazes on a grid of square cells: random perfect mazes and a small text format.

A maze of R rows and C columns has cell (row, col) centred at ``((col + 0.5) s, (row + 0.5) s)`` in
the world frame, ``s`` the cell size in metres; row 0 is at the bottom (y grows upwards, as in a
plot). Walls lie on the grid lines:

* ``horizontal[i, c]`` — a wall along ``y = i s`` under cell (i, c), ``i`` in 0..R;
* ``vertical[r, j]`` — a wall along ``x = j s`` left of cell (r, j), ``j`` in 0..C.

The text format draws the maze as seen from above (the top line is the highest row)::

    # comments start with '#'; parameters are 'key = value' lines before the drawing
    cell_size = 0.15
    wall_thickness = 0.01
    start = 0 0
    +---+---+
    |       |
    +   +---+
    |   |   |
    +---+---+

'+' marks every grid vertex, '-' a horizontal wall between two '+', '|' a vertical wall. The
outer boundary must be closed. ``start`` is the start cell as ``row col`` (row 0 = bottom line).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

#: Default cell size, metres: a corridor the e-puck (74 mm across) drives along with room to turn.
DEFAULT_CELL_SIZE = 0.15
#: Default wall thickness, metres (card or wooden walls of a table-top maze).
DEFAULT_WALL_THICKNESS = 0.01


class MazeFormatError(ValueError):
    """A maze text that cannot be read; the message names the file, the line and the reason."""


@dataclass
class Maze:
    """Walls of a grid maze. Shapes: ``horizontal`` (R+1, C), ``vertical`` (R, C+1), both bool."""

    horizontal: np.ndarray
    vertical: np.ndarray
    cell_size: float = DEFAULT_CELL_SIZE
    wall_thickness: float = DEFAULT_WALL_THICKNESS
    start_cell: tuple[int, int] = (0, 0)
    name: str = "maze"
    seed: int | None = None
    metadata: dict = field(default_factory=dict)

    def __post_init__(self):
        self.horizontal = np.asarray(self.horizontal, dtype=bool)
        self.vertical = np.asarray(self.vertical, dtype=bool)
        rows, cols = self.vertical.shape[0], self.horizontal.shape[1]
        if rows < 1 or cols < 1:
            raise ValueError(f"a maze needs at least one cell, got {rows} x {cols}")
        if self.horizontal.shape != (rows + 1, cols) or self.vertical.shape != (rows, cols + 1):
            raise ValueError(
                f"wall arrays disagree: horizontal {self.horizontal.shape}, vertical {self.vertical.shape}"
            )
        if not (0 < self.wall_thickness < self.cell_size <= 1000):
            raise ValueError(
                f"wall thickness {self.wall_thickness} m must be positive and below the cell size "
                f"{self.cell_size} m (at most 1000 m)"
            )
        closed = (
            self.horizontal[0].all()
            and self.horizontal[-1].all()
            and self.vertical[:, 0].all()
            and self.vertical[:, -1].all()
        )
        if not closed:
            raise ValueError("the maze's outer boundary must be closed (a wall on every border edge)")
        row, col = self.start_cell
        if not (0 <= row < rows and 0 <= col < cols):
            raise ValueError(f"start cell {self.start_cell} is outside the {rows} x {cols} maze")

    @property
    def rows(self) -> int:
        return self.vertical.shape[0]

    @property
    def cols(self) -> int:
        return self.horizontal.shape[1]

    @property
    def size(self) -> tuple[float, float]:
        """Width and height of the maze in metres (between wall centre lines)."""
        return self.cols * self.cell_size, self.rows * self.cell_size

    def cell_center(self, row: int, col: int) -> np.ndarray:
        """World position (x, y) of the centre of cell (row, col), metres."""
        return np.array([(col + 0.5) * self.cell_size, (row + 0.5) * self.cell_size])

    def cell_of(self, x: float, y: float) -> tuple[int, int]:
        """The cell (row, col) containing world point (x, y), clipped to the maze."""
        col = min(max(math.floor(x / self.cell_size), 0), self.cols - 1)
        row = min(max(math.floor(y / self.cell_size), 0), self.rows - 1)
        return row, col

    def neighbours(self, row: int, col: int) -> list[tuple[int, int]]:
        """Cells reachable from (row, col) in one step (no wall in between)."""
        result = []
        if not self.horizontal[row, col]:
            result.append((row - 1, col))
        if not self.horizontal[row + 1, col]:
            result.append((row + 1, col))
        if not self.vertical[row, col]:
            result.append((row, col - 1))
        if not self.vertical[row, col + 1]:
            result.append((row, col + 1))
        return result

    def to_text(self) -> str:
        """The maze in the text format (parameters, then the drawing); ``parse_maze`` reads it back."""
        lines = [
            f"cell_size = {self.cell_size!r}",
            f"wall_thickness = {self.wall_thickness!r}",
            f"start = {self.start_cell[0]} {self.start_cell[1]}",
        ]
        for i in range(self.rows, -1, -1):
            lines.append("+" + "+".join("---" if wall else "   " for wall in self.horizontal[i]) + "+")
            if i > 0:
                r = i - 1
                cells = "".join(("|" if self.vertical[r, j] else " ") + "   " for j in range(self.cols))
                lines.append(cells + ("|" if self.vertical[r, self.cols] else " "))
        return "\n".join(lines) + "\n"


def generate_maze(
    rows: int,
    cols: int,
    rng: np.random.Generator | int | None = None,
    cell_size: float = DEFAULT_CELL_SIZE,
    wall_thickness: float = DEFAULT_WALL_THICKNESS,
    loop_fraction: float = 0.0,
) -> Maze:
    """A random perfect maze (every cell reachable by exactly one path), by randomised depth-first search.

    ``loop_fraction`` in [0, 1] then removes that fraction of the remaining interior walls, so the
    maze has loops (more chances for SLAM to close a loop). ``rng`` is a Generator or a seed.
    """
    if rows < 1 or cols < 1:
        raise ValueError(f"a maze needs at least one row and one column, got {rows} x {cols}")
    if not 0.0 <= loop_fraction <= 1.0:
        raise ValueError(f"loop_fraction must be in [0, 1], got {loop_fraction}")
    seed = rng if isinstance(rng, (int, np.integer)) else None
    rng = np.random.default_rng(rng)
    horizontal = np.ones((rows + 1, cols), dtype=bool)
    vertical = np.ones((rows, cols + 1), dtype=bool)
    visited = np.zeros((rows, cols), dtype=bool)
    stack = [(0, 0)]
    visited[0, 0] = True
    steps = ((-1, 0), (1, 0), (0, -1), (0, 1))
    while stack:
        row, col = stack[-1]
        options = [
            (row + dr, col + dc)
            for dr, dc in steps
            if 0 <= row + dr < rows and 0 <= col + dc < cols and not visited[row + dr, col + dc]
        ]
        if not options:
            stack.pop()
            continue
        nrow, ncol = options[rng.integers(len(options))]
        _remove_wall_between(horizontal, vertical, (row, col), (nrow, ncol))
        visited[nrow, ncol] = True
        stack.append((nrow, ncol))
    if loop_fraction > 0:
        interior_h = np.argwhere(horizontal[1:-1]) + (1, 0)
        interior_v = np.argwhere(vertical[:, 1:-1]) + (0, 1)
        for walls, array in ((interior_h, horizontal), (interior_v, vertical)):
            chosen = rng.random(len(walls)) < loop_fraction
            array[tuple(walls[chosen].T)] = False
    return Maze(
        horizontal,
        vertical,
        cell_size,
        wall_thickness,
        (0, 0),
        name=f"random-{rows}x{cols}",
        seed=None if seed is None else int(seed),
    )


def _remove_wall_between(horizontal, vertical, a, b):
    """Open the wall between neighbouring cells a and b, both (row, col)."""
    (ra, ca), (rb, cb) = a, b
    if ra == rb:
        vertical[ra, max(ca, cb)] = False
    else:
        horizontal[max(ra, rb), ca] = False


def parse_maze(text: str, source: str = "<text>") -> Maze:
    """Read a maze from the text format described in this module's docstring."""
    params: dict[str, str] = {}
    drawing: list[tuple[int, str]] = []
    for number, raw in enumerate(text.splitlines(), start=1):
        line = raw.rstrip()
        stripped = line.strip()
        if drawing or stripped.startswith("+"):
            if stripped and not stripped.startswith("#"):
                drawing.append((number, line))
            continue
        if not stripped or stripped.startswith("#"):
            continue
        if "=" not in stripped:
            shown = stripped if len(stripped) <= 40 else stripped[:37] + "..."
            raise MazeFormatError(
                f"{source}:{number}: not a maze file: expected 'key = value' or the '+---+' drawing, got {shown!r}"
            )
        key, value = (part.strip() for part in stripped.split("=", 1))
        params[key] = value
    if len(drawing) < 3 or len(drawing) % 2 == 0:
        raise MazeFormatError(
            f"{source}: the drawing needs an odd number (at least 3) of lines alternating '+' wall "
            f"lines and '|' cell lines, found {len(drawing)}"
        )
    first_number, first = drawing[0]
    posts = [i for i, ch in enumerate(first) if ch == "+"]
    if len(posts) < 2:
        raise MazeFormatError(f"{source}:{first_number}: a wall line needs at least two '+'")
    rows, cols = len(drawing) // 2, len(posts) - 1
    from mazeslam.core.limits import maze_problem

    too_big = maze_problem(rows, cols)
    if too_big:
        raise MazeFormatError(f"{source}: {too_big}")
    horizontal = np.zeros((rows + 1, cols), dtype=bool)
    vertical = np.zeros((rows, cols + 1), dtype=bool)
    for k, (number, line) in enumerate(drawing):
        padded = line.ljust(posts[-1] + 1)
        if k % 2 == 0:
            if [i for i, ch in enumerate(padded) if ch == "+"] != posts:
                raise MazeFormatError(f"{source}:{number}: '+' marks are not aligned with line {first_number}")
            i = rows - k // 2
            for c in range(cols):
                span = padded[posts[c] + 1 : posts[c + 1]]
                if set(span) - {"-", " "} or (span.strip() and set(span) != {"-"}):
                    raise MazeFormatError(f"{source}:{number}: wall span {span!r} must be all '-' or all spaces")
                horizontal[i, c] = span.startswith("-")
        else:
            r = rows - 1 - k // 2
            for j, position in enumerate(posts):
                if padded[position] not in "| ":
                    raise MazeFormatError(
                        f"{source}:{number}: expected '|' or a space at column {position + 1}, got {padded[position]!r}"
                    )
                vertical[r, j] = padded[position] == "|"
    try:
        start = tuple(int(v) for v in params.pop("start", "0 0").split())
        cell_size = float(params.pop("cell_size", DEFAULT_CELL_SIZE))
        wall_thickness = float(params.pop("wall_thickness", DEFAULT_WALL_THICKNESS))
    except ValueError as error:
        raise MazeFormatError(f"{source}: bad parameter value: {error}") from error
    if params:
        raise MazeFormatError(f"{source}: unknown parameter(s) {', '.join(sorted(key[:40] for key in params))}")
    if len(start) != 2:
        raise MazeFormatError(f"{source}: start must be 'row col', got {start}")
    try:
        return Maze(horizontal, vertical, cell_size, wall_thickness, start, name=Path(source).stem)
    except ValueError as error:
        raise MazeFormatError(f"{source}: {error}") from error


def load_maze(path: str | Path) -> Maze:
    """Read a maze text file (see ``parse_maze``)."""
    from mazeslam.core.config import InputError, read_text

    path = Path(path)
    try:
        text = read_text(path, "maze file")
    except (FileNotFoundError, InputError) as error:
        raise MazeFormatError(str(error)) from error
    return parse_maze(text, str(path))
