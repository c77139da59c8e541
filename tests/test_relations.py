"""The relation metric (Kümmerle et al. 2009) on hand-computed cases."""

import numpy as np
import pytest

from mazeslam.evaluation.relations import relation_errors, relation_metric, spatial_relations
from mazeslam.geometry import compose

REFERENCE = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, np.pi / 2]])
#: Pose 1 off by 0.2 m to its left, pose 2 turned 0.1 rad too far.
ESTIMATE = np.array([[0.0, 0.0, 0.0], [1.0, 0.2, 0.0], [1.0, 1.0, np.pi / 2 + 0.1]])
PAIRS = np.array([[0, 1], [1, 2], [0, 2]])


def test_relation_errors_by_hand():
    # (0, 1): reference motion (1, 0, 0), ours (1, 0.2, 0): 0.2 m to the left in pose 0's frame.
    # (1, 2): reference (0, 1, pi/2), ours (0, 0.8, pi/2 + 0.1): 0.2 m short along the reference's
    #         heading pi/2, seen from the reference's end pose: (-0.2, 0), and 0.1 rad.
    # (0, 2): the same end pose, turned 0.1 rad.
    errors = relation_errors(ESTIMATE, REFERENCE, PAIRS)
    np.testing.assert_allclose(errors, [[0.0, 0.2, 0.0], [-0.2, 0.0, 0.1], [0.0, 0.0, 0.1]], atol=1e-12)


def test_relation_metric_by_hand_and_frame_free():
    metric = relation_metric(ESTIMATE, REFERENCE, PAIRS)
    assert metric["relations"] == 3
    assert metric["trans_mean"] == pytest.approx(0.4 / 3)
    assert metric["trans_sq_mean"] == pytest.approx(0.08 / 3)
    assert metric["trans_std"] == pytest.approx(np.std([0.2, 0.2, 0.0]))
    assert metric["rot_mean"] == pytest.approx(0.2 / 3)
    assert metric["rot_sq_mean"] == pytest.approx(0.02 / 3)
    # No alignment needed: the estimate in another world frame scores the same.
    moved = compose(np.array([5.0, -3.0, 2.0]), ESTIMATE)
    assert relation_metric(moved, REFERENCE, PAIRS) == pytest.approx(metric)


def test_spatial_relations_within_radius():
    # Distances: 0-1 1 m, 1-2 1 m, 0-2 sqrt(2) m.
    np.testing.assert_array_equal(spatial_relations(REFERENCE, 1.2), [[0, 1], [1, 2]])
    np.testing.assert_array_equal(spatial_relations(REFERENCE, 1.5), [[0, 1], [0, 2], [1, 2]])
    np.testing.assert_array_equal(spatial_relations(REFERENCE, 1.5, min_gap=2), [[0, 2]])
    assert spatial_relations(REFERENCE, 0.5).shape == (0, 2)


def test_bad_input_is_named():
    with pytest.raises(ValueError, match="radius"):
        spatial_relations(REFERENCE, 0.0)
    with pytest.raises(ValueError, match=r"\(S, 3\)"):
        relation_errors(ESTIMATE[:, :2], REFERENCE, PAIRS)
    with pytest.raises(ValueError, match="no relations"):
        relation_metric(ESTIMATE, REFERENCE, np.zeros((0, 2), dtype=int))
