"""Mapping with known poses: the scans of a simulated building placed at their true poses give a
map whose occupied cells lie on the true walls, and whose free cells are inside the corridors."""

import numpy as np
import pytest
from test_grid_slam import distance_to_walls

from mazeslam.data.log import read
from mazeslam.data.map_io import FREE, OCCUPIED
from mazeslam.gridslam.known_poses import map_at_poses
from mazeslam.gridslam.occupancy import GridParams, grid_states
from mazeslam.sim.building import building_walls, simulate_building_log


@pytest.fixture(scope="module")
def building(tmp_path_factory):
    simulated = simulate_building_log(tmp_path_factory.mktemp("known") / "building.log", laps=0.6)
    return simulated, read(simulated.path)


def cell_centres(occupancy, state) -> np.ndarray:
    cells = np.argwhere(occupancy.states == state)
    return occupancy.origin[:2] + (cells + 0.5) * occupancy.resolution


def test_the_scans_at_their_true_poses_draw_the_true_walls(building):
    simulated, course_log = building
    poses = simulated.truth[course_log.is_scan]
    occupancy = grid_states(map_at_poses(course_log, simulated.geometry, poses, GridParams()))
    walls = building_walls()
    occupied, free = cell_centres(occupancy, OCCUPIED), cell_centres(occupancy, FREE)
    assert len(occupied) > 500
    assert np.mean(distance_to_walls(occupied, walls) < 0.075) > 0.97  # 5 cm cells: within 1.5 cells
    inner = (free[:, 0] > 2.0) & (free[:, 0] < 14.0) & (free[:, 1] > 2.0) & (free[:, 1] < 8.0)
    assert not inner.any()  # nothing seen through the inner block's walls


def test_a_pose_per_scan_is_required(building):
    simulated, course_log = building
    with pytest.raises(ValueError, match="poses for .* scans"):
        map_at_poses(course_log, simulated.geometry, simulated.truth[:3], GridParams())
