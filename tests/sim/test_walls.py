from collections import Counter

import numpy as np
import pytest

from mazeslam.sim.laser import RayCaster
from mazeslam.sim.maze import generate_maze, parse_maze
from mazeslam.sim.walls import WallsInSight, wall_geometry


def as_set(rows):
    return {tuple(np.round(row, 9)) for row in rows}


def test_single_cell_is_a_square_room():
    maze = parse_maze("cell_size = 1\nwall_thickness = 0.1\n+---+\n|   |\n+---+\n")
    walls = wall_geometry(maze)
    assert as_set(walls.surfaces) == {
        (0.05, 0.05, 0.05, 0.95),
        (0.95, 0.05, 0.95, 0.95),
        (0.05, 0.05, 0.95, 0.05),
        (0.05, 0.95, 0.95, 0.95),
    }
    assert as_set(walls.corners) == {(0.05, 0.05), (0.95, 0.05), (0.05, 0.95), (0.95, 0.95)}
    assert not walls.corner_convex.any()  # all four are inside corners


def test_l_shaped_wall_hand_computed():
    # Bottom row split by a wall at x = 1, which turns right along y = 1: the free space is an L
    # (left column and top row) plus a closed cell at the bottom right.
    maze = parse_maze("cell_size = 1\nwall_thickness = 0.1\n+---+---+\n|       |\n+   +---+\n|   |   |\n+---+---+\n")
    walls = wall_geometry(maze)
    assert as_set(walls.surfaces) == {
        (0.05, 0.05, 0.05, 1.95),
        (0.05, 1.95, 1.95, 1.95),
        (1.95, 1.05, 1.95, 1.95),  # L's outer walls
        (0.05, 0.05, 0.95, 0.05),
        (0.95, 0.05, 0.95, 1.05),
        (0.95, 1.05, 1.95, 1.05),  # L's inner side
        (1.05, 0.05, 1.95, 0.05),
        (1.05, 0.05, 1.05, 0.95),  # the closed cell
        (1.05, 0.95, 1.95, 0.95),
        (1.95, 0.05, 1.95, 0.95),
    }
    convex = {tuple(c) for c in np.round(walls.corners[walls.corner_convex], 9)}
    concave = {tuple(c) for c in np.round(walls.corners[~walls.corner_convex], 9)}
    assert convex == {(0.95, 1.05)}  # the tip of the L seen from the corridor
    assert concave == {
        (0.05, 0.05),
        (0.95, 0.05),
        (0.05, 1.95),
        (1.95, 1.95),
        (1.95, 1.05),
        (1.05, 0.05),
        (1.95, 0.05),
        (1.05, 0.95),
        (1.95, 0.95),
    }


def test_wall_end_has_two_convex_corners():
    # A wall sticking into a 1 x 2 room from the bottom: its free end has two convex corners.
    maze = parse_maze("cell_size = 1\nwall_thickness = 0.1\n+---+---+\n|       |\n+---+---+\n")
    assert not wall_geometry(maze).corner_convex.any()
    maze = parse_maze("cell_size = 1\nwall_thickness = 0.1\n+---+---+\n|       |\n+   +   +\n|   |   |\n+---+---+\n")
    walls = wall_geometry(maze)
    convex = as_set(walls.corners[walls.corner_convex])
    assert convex == {(0.95, 1.05), (1.05, 1.05)}


@pytest.mark.parametrize("seed", range(4))
def test_corners_are_exactly_where_two_perpendicular_surfaces_end(seed):
    walls = wall_geometry(generate_maze(7, 9, seed, loop_fraction=0.2))
    endpoints = Counter(as_set([s[:2]]).pop() for s in walls.surfaces)
    endpoints.update(as_set([s[2:]]).pop() for s in walls.surfaces)
    assert set(endpoints) == as_set(walls.corners)
    assert set(endpoints.values()) == {2}
    for corner in walls.corners:
        touching = [s for s in walls.surfaces if np.allclose(s[:2], corner) or np.allclose(s[2:], corner)]
        d0, d1 = (np.subtract(s[2:], s[:2]) for s in touching)
        assert abs(np.dot(d0, d1)) < 1e-12  # perpendicular


def test_boxes_cover_exactly_the_solid_area():
    maze = generate_maze(5, 5, 1)
    walls = wall_geometry(maze)
    s, t = maze.cell_size, maze.wall_thickness
    area = np.prod(walls.boxes[:, 2:] - walls.boxes[:, :2], axis=1).sum()
    # The free area is 25 cell interiors of (s - t)^2 plus the (s - t) x t openings of removed walls.
    openings = (~maze.horizontal).sum() + (~maze.vertical).sum()
    free = 25 * (s - t) ** 2 + openings * (s - t) * t
    total = (5 * s + t) ** 2
    assert area == pytest.approx(total - free)


@pytest.mark.parametrize("loops", [0.0, 0.3])
def test_walls_in_sight_give_the_same_hits_as_every_wall(loops):
    maze = generate_maze(10, 10, 3, loop_fraction=loops, cell_size=0.15, wall_thickness=0.01)
    geometry = wall_geometry(maze)
    surfaces, boxes = geometry.surfaces, geometry.boxes
    bearings = np.linspace(-np.pi, np.pi, 720, endpoint=False)
    caster = RayCaster(surfaces, bearings, 0.8)
    in_sight = WallsInSight(maze, surfaces, 0.8)
    rng = np.random.default_rng(0)
    fewer = 0
    for _ in range(600):  # anywhere free: cell interiors and open walls' gaps
        x, y = rng.uniform(0.0, 1.5, 2)
        if ((boxes[:, :2] <= (x, y)) & ((x, y) <= boxes[:, 2:])).all(axis=1).any():
            continue  # inside a wall
        candidates = in_sight.walls(x, y)
        fewer += len(candidates) < len(surfaces)
        everything, walls, fractions = caster.hits(x, y, 0.3)
        np.testing.assert_array_equal(caster.hits(x, y, 0.3, candidates)[0], everything)
        np.testing.assert_array_equal(caster.hits(x, y, 0.3, candidates)[1], walls)
    assert fewer > 100
