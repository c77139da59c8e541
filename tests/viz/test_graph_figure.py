"""The pose graph's figure: its closures drawn as segments between the right nodes, counted in the legend."""

import matplotlib.image
import numpy as np
from matplotlib.figure import Figure

from mazeslam.data.map_io import FREE, OCCUPIED, OccupancyMap
from mazeslam.viz import graph_figure


def test_each_closure_is_a_segment_between_its_two_nodes():
    poses = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 2.0, 0.0], [0.0, 2.0, 1.0]])
    x, y = graph_figure._segments(poses, np.array([[0, 2], [3, 1]]))
    np.testing.assert_array_equal(x, [0.0, 1.0, np.nan, 0.0, 1.0, np.nan])
    np.testing.assert_array_equal(y, [0.0, 2.0, np.nan, 2.0, 0.0, np.nan])


def test_the_figure_names_kept_and_rejected_closures(tmp_path, monkeypatch):
    states = np.full((60, 60), FREE, dtype=np.int8)
    states[:, 0] = OCCUPIED
    occupancy = OccupancyMap(states, 0.05, np.array([-0.5, -0.5, 0.0]))
    angles = np.linspace(0, 2 * np.pi, 40)
    poses = np.column_stack([1 + np.cos(angles), 1 + np.sin(angles), angles])
    figures = []
    original = Figure.savefig
    monkeypatch.setattr(Figure, "savefig", lambda fig, *a, **k: (figures.append(fig), original(fig, *a, **k))[1])
    path = graph_figure.plot_pose_graph(
        tmp_path / "smooth.png", occupancy, poses, np.array([[39, 0]]), np.array([[20, 2], [30, 5]]), "a ring"
    )
    assert matplotlib.image.imread(path).shape[0] > 300
    labels = [text.get_text() for legend in figures[0].legends for text in legend.get_texts()]
    assert "loop closures kept (1)" in labels and "loop closures rejected (2)" in labels
    assert "nodes (40 scans)" in labels
