import numpy as np
import pytest

from mazeslam.data import sidecars


def test_sidecar_names_sit_beside_the_log():
    assert str(sidecars.truth_path("runs/demo.log")) == "runs/demo.truth.csv"
    assert str(sidecars.map_path("runs/demo.log")) == "runs/demo.map.json"


def test_truth_round_trip_and_header(tmp_path):
    path = tmp_path / "a.truth.csv"
    times = np.array([0.0, 0.2])
    poses = np.array([[0.1, 0.2, 0.3], [0.4, 0.5, -3.0]])
    sidecars.write_truth(path, times, poses)
    assert path.read_text().splitlines()[0] == "t,x,y,theta"
    t, p = sidecars.read_truth(path)
    np.testing.assert_allclose(t, times)
    np.testing.assert_allclose(p, poses)


def test_truth_with_wrong_header_is_refused(tmp_path):
    path = tmp_path / "b.truth.csv"
    path.write_text("time,x,y\n0,0,0\n")
    with pytest.raises(ValueError, match="header"):
        sidecars.read_truth(path)


def test_map_round_trip(tmp_path):
    path = tmp_path / "a.map.json"
    sidecars.write_map(path, [[0, 0, 1, 0]], [[0, 0], [1, 0]], {"beams": 4, "first_beam_angle": 0.0}, seed=3)
    document = sidecars.read_map(path)
    np.testing.assert_allclose(document["walls"], [[0, 0, 1, 0]])
    assert document["corners"].shape == (2, 2)
    assert document["seed"] == 3
    assert sidecars.beam_geometry(document["sensor"]).first_beam_angle == 0.0


def test_map_without_walls_is_refused(tmp_path):
    path = tmp_path / "c.map.json"
    path.write_text('{"corners": [], "sensor": {}}')
    with pytest.raises(ValueError, match="lacks walls"):
        sidecars.read_map(path)
