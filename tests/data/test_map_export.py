"""Map export: the occupancy grid from scans along a path (ROS map_server files) and landmarks.csv."""

import json

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from mazeslam.cli.main import main
from mazeslam.data.loaded_run import load_run
from mazeslam.data.map_export import choose_resolution, export_map, occupancy_from_scans
from mazeslam.data.map_io import FREE, OCCUPIED, read_map
from mazeslam.data.scans import scan_points_world


@pytest.fixture(scope="module")
def short_run(tmp_path_factory):
    from mazeslam import simulate

    out = tmp_path_factory.mktemp("map_export") / "short.log"
    simulate(out, seed=2, duration=20.0, progress=False)
    return load_run(out)


def test_resolution_follows_the_extent():
    assert choose_resolution(0.7) == 0.01  # a course maze
    assert choose_resolution(60.0) == 0.05  # a building
    assert choose_resolution(1000.0) * 4000 >= 1000.0  # never more than 4000 pixels a side


def pixel(description: dict, image: np.ndarray, x: float, y: float) -> int:
    """The PGM value at world (x, y) by the map_server convention (row 0 at the top, origin lower-left)."""
    ox, oy, _ = description["origin"]
    column = int(np.floor((x - ox) / description["resolution"]))
    row = image.shape[0] - 1 - int(np.floor((y - oy) / description["resolution"]))
    return int(image[row, column])


def read_pgm(path) -> np.ndarray:
    data = path.read_bytes()
    magic, size, depth, pixels = data.split(b"\n", 3)
    width, height = (int(v) for v in size.split())
    assert magic == b"P5" and depth == b"255"
    return np.frombuffer(pixels, dtype=np.uint8).reshape(height, width)


def test_known_walls_are_occupied_and_the_path_free(short_run, tmp_path):
    run = short_run
    occupancy = occupancy_from_scans(run.log, run.truth, run.geometry)
    paths = export_map(tmp_path, occupancy, np.zeros((0, 2)), np.zeros((0, 2, 2)))
    description = yaml.safe_load(paths["occupancy"].read_text())
    assert set(description) >= {"image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh"}
    assert description["image"] == "occupancy.pgm" and description["resolution"] == 0.01
    image = read_pgm(tmp_path / description["image"])
    hits = scan_points_world(run.log, run.truth, run.geometry)
    # Points on the true walls that a scan returned from: their pixel (or a neighbour) is black.
    checked = 0
    for x1, y1, x2, y2 in run.walls:
        for t in np.linspace(0, 1, 50):
            point = np.array([x1 + t * (x2 - x1), y1 + t * (y2 - y1)])
            if np.hypot(*(hits - point).T).min() > 0.002:
                continue
            around = [
                pixel(description, image, *(point + offset))
                for offset in 0.01 * np.array([[0, 0], [1, 0], [-1, 0], [0, 1], [0, -1]])
            ]
            assert 0 in around, point
            checked += 1
    assert checked > 20
    # Where the robot drove is free (254), read by the map_server rule and by read_map alike.
    for x, y, _ in run.truth[:: max(1, len(run.truth) // 20)]:
        assert pixel(description, image, x, y) == 254
    read_back = read_map(paths["occupancy"])
    assert read_back.resolution == 0.01
    assert (read_back.states == OCCUPIED).sum() > 50 and (read_back.states == FREE).sum() > 500
    grid = occupancy_from_scans(run.log, run.truth, run.geometry)
    np.testing.assert_array_equal(read_back.states, grid.states)


def test_beyond_max_range_only_clears(short_run):
    run = short_run
    near = occupancy_from_scans(run.log, run.truth, run.geometry, max_range=0.05, resolution=0.01)
    far = occupancy_from_scans(run.log, run.truth, run.geometry, resolution=0.01)
    assert (near.states == OCCUPIED).sum() < (far.states == OCCUPIED).sum() / 2


def test_slam_writes_the_map_files(short_run, tmp_path):
    out = tmp_path / "out"
    result = CliRunner().invoke(main, ["slam", str(short_run.path), "--out", str(out), "--quiet"])
    assert result.exit_code == 0, result.output
    for name in ["occupancy.pgm", "occupancy.yaml", "occupancy.png", "landmarks.csv"]:
        assert (out / name).stat().st_size > 0, name
    rows = (out / "landmarks.csv").read_text().splitlines()
    assert rows[0] == "x,y,cov_xx,cov_xy,cov_yy"

    landmarks = json.loads((out / "map.json").read_text())["landmarks"]
    assert len(rows) - 1 == len(landmarks)
    first = np.array(rows[1].split(","), dtype=float)
    np.testing.assert_allclose(first[:2], landmarks[0], atol=1e-6)
    assert read_map(out / "occupancy.yaml").states.size > 0
