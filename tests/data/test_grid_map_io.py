"""Occupancy maps in the ROS map_server convention (YAML + PGM), read back."""

import numpy as np
import yaml

from mazeslam.data.map_io import FREE, OCCUPIED, UNKNOWN, OccupancyMap, read_map, to_image, write_map


def test_a_written_map_reads_back_the_same(tmp_path):
    rng = np.random.default_rng(0)
    states = rng.choice(np.array([UNKNOWN, FREE, OCCUPIED], dtype=np.int8), size=(37, 23))
    written = OccupancyMap(states, 0.05, np.array([-3.2, 1.6, 0.0]))
    path = write_map(written, tmp_path)
    description = yaml.safe_load(path.read_text())
    assert description["image"] == "occupancy.pgm" and description["negate"] == 0
    assert description["resolution"] == 0.05 and description["origin"] == [-3.2, 1.6, 0.0]
    assert 0 < description["free_thresh"] < description["occupied_thresh"] < 1
    assert (tmp_path / "occupancy.pgm").read_bytes().startswith(b"P5\n37 23\n255\n")  # width (x), height (y)
    assert sorted(path.name for path in tmp_path.iterdir()) == ["occupancy.pgm", "occupancy.yaml"]  # map_server's pair
    back = read_map(path)
    np.testing.assert_array_equal(back.states, states)
    assert back.resolution == 0.05
    np.testing.assert_allclose(back.origin, written.origin)


def test_the_image_puts_large_y_at_the_top_and_the_origin_at_the_lower_left():
    states = np.full((4, 3), FREE, dtype=np.int8)
    states[0, 2] = OCCUPIED  # smallest x, largest y: top-left pixel
    image = to_image(states)
    assert image.shape == (3, 4)
    assert image[0, 0] == 0 and image[-1, 0] == 254
