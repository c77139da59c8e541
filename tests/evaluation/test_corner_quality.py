"""Corner extraction against the true corners of simulated mazes (issue 3's quality bar)."""

import dataclasses

import numpy as np
import pytest

from mazeslam import simulate
from mazeslam.evaluation.corner_quality import corner_faces, evaluate_log, observable_corners
from mazeslam.features.corners import CornerParams
from mazeslam.sim.laser import RayCaster
from mazeslam.sim.simulator import MazeParams, SimulationConfig


@pytest.fixture(scope="module")
def maze_logs(tmp_path_factory):
    folder = tmp_path_factory.mktemp("quality")
    config = dataclasses.replace(SimulationConfig(), maze=MazeParams(rows=5, cols=5))
    return [
        simulate(folder / f"maze{seed}.log", config=config, seed=seed, duration=90, progress=False).log_path
        for seed in (11, 12, 13)
    ]


def test_precision_and_recall_within_2cm_at_default_noise(maze_logs):
    for path in maze_logs:
        result = evaluate_log(path, tolerance=0.02)
        assert result["observable"] > 200, result
        assert result["precision"] >= 0.95, result
        assert result["recall"] >= 0.90, result


def test_observability_of_a_hand_made_room():
    walls = np.array([[0, 0, 1, 0], [1, 0, 1, 1], [1, 1, 0, 1], [0, 1, 0, 0]], dtype=float)
    corners = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=float)
    bearings = np.linspace(-np.pi, np.pi, 180, endpoint=False)
    caster = RayCaster(walls, bearings, 3.0)
    faces = corner_faces(walls, corners)
    assert all(len(f) == 2 for f in faces)
    seen = observable_corners(
        (0.3, 0.4, 0.0), caster, 2 * np.pi / 180, corners, faces, np.zeros(4, bool), CornerParams(), max_range=3.0
    )
    assert seen.all()
    near_only = observable_corners(
        (0.2, 0.2, 0.0), caster, 2 * np.pi / 180, corners, faces, np.zeros(4, bool), CornerParams(), max_range=0.5
    )
    assert near_only.tolist() == [True, False, False, False]
