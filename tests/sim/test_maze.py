import re

import numpy as np
import pytest
from conftest import PROJECT_ROOT

from mazeslam.sim.maze import MazeFormatError, generate_maze, load_maze, parse_maze
from mazeslam.sim.policies import shortest_path

CONFIG_MAZES = PROJECT_ROOT / "configs" / "mazes"


def open_interior_walls(maze):
    return int((~maze.horizontal[1:-1]).sum() + (~maze.vertical[:, 1:-1]).sum())


@pytest.mark.parametrize("rows, cols, seed", [(1, 1, 0), (1, 7, 1), (5, 5, 2), (16, 16, 3)])
def test_random_maze_is_perfect(rows, cols, seed):
    maze = generate_maze(rows, cols, seed)
    assert open_interior_walls(maze) == rows * cols - 1  # a spanning tree of the cells
    for row in range(rows):
        for col in range(cols):
            assert shortest_path(maze, (0, 0), (row, col))[-1] == (row, col)


def test_random_maze_is_seeded():
    a, b, c = generate_maze(6, 6, 11), generate_maze(6, 6, 11), generate_maze(6, 6, 12)
    assert np.array_equal(a.horizontal, b.horizontal) and np.array_equal(a.vertical, b.vertical)
    assert not (np.array_equal(a.horizontal, c.horizontal) and np.array_equal(a.vertical, c.vertical))


def test_loop_fraction_opens_extra_walls():
    assert open_interior_walls(generate_maze(8, 8, 5, loop_fraction=0.3)) > 8 * 8 - 1


def test_text_round_trip():
    maze = generate_maze(4, 6, 3, cell_size=0.2, wall_thickness=0.02)
    again = parse_maze(maze.to_text())
    assert np.array_equal(again.horizontal, maze.horizontal)
    assert np.array_equal(again.vertical, maze.vertical)
    assert (again.cell_size, again.wall_thickness, again.start_cell) == (0.2, 0.02, (0, 0))


def test_parse_hand_drawn_maze():
    maze = parse_maze("start = 1 0\n+---+---+\n|       |\n+   +---+\n|   |   |\n+---+---+\n")
    assert (maze.rows, maze.cols, maze.start_cell) == (2, 2, (1, 0))
    # Middle line is y = 1 cell: open over column 0, a wall over column 1.
    assert maze.horizontal[1].tolist() == [False, True]
    # Bottom row (row 0) has a wall between its two cells; the top row does not.
    assert maze.vertical[0].tolist() == [True, True, True]
    assert maze.vertical[1].tolist() == [True, False, True]


def test_shipped_mazes_load():
    paper = load_maze(CONFIG_MAZES / "paper_sheet.txt")
    assert (paper.rows, paper.cols, paper.cell_size) == (3, 4, 0.14)
    large = load_maze(CONFIG_MAZES / "large_8x8.txt")
    assert (large.rows, large.cols) == (8, 8)


@pytest.mark.parametrize(
    "text, message",
    [
        ("+---+\n|    \n+---+\n", "outer boundary must be closed"),
        ("+---+---+\n|       |\n+---+--+\n", ":3: '+' marks are not aligned"),
        ("+-- +\n|   |\n+---+\n", ":1: wall span"),
        ("+---+\n|   *\n+---+\n", ":2: expected '|' or a space"),
        ("size = 3\n+---+\n|   |\n+---+\n", "unknown parameter(s) size"),
        ("+---+\n|   |\n", "odd number"),
        ("start = 3 3\n+---+\n|   |\n+---+\n", "outside"),
        ("cell_size = 0.1\nwall_thickness = 0.2\n+---+\n|   |\n+---+\n", "below the cell size"),
        ("cell_size = wide\n+---+\n|   |\n+---+\n", "bad parameter value"),
    ],
)
def test_bad_maze_text_names_line_and_reason(text, message):
    with pytest.raises(MazeFormatError, match=re.escape(message)) as error:
        parse_maze(text, "m.txt")
    assert str(error.value).startswith("m.txt")


def test_missing_maze_file(tmp_path):
    with pytest.raises(MazeFormatError, match="not found"):
        load_maze(tmp_path / "nope.txt")
