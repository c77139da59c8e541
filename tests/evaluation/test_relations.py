"""The relation metric (Kümmerle et al. 2009) on hand-computed cases."""

import numpy as np
import pytest
from click.testing import CliRunner

from mazeslam.cli.main import main
from mazeslam.core.config import InputError
from mazeslam.core.geometry import compose, relative
from mazeslam.data.sidecars import write_trajectory, write_truth
from mazeslam.evaluation.relations import (
    pairs_at_times,
    read_relations,
    relation_errors,
    relation_metric,
    relations_metric,
    spatial_relations,
)

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


# --- relations files (the benchmark's text format) ---------------------------------------------------

#: The times of REFERENCE's and ESTIMATE's three poses, s.
TIMES = np.array([10.0, 10.5, 11.0])


def _relations_text(pairs=PAIRS, times=TIMES, reference=REFERENCE) -> str:
    """The relations of ``pairs`` written by hand from the reference poses: ``t1 t2 x y z roll pitch yaw``."""
    lines = ["# t1 t2 x y z roll pitch yaw"]
    for i, j in pairs:
        x, y, yaw = relative(reference[i], reference[j])
        lines.append(f"{times[i]:.3f} {times[j]:.3f} {x:.9f} {y:.9f} 0 0 0 {yaw:.9f}")
    return "\n".join(lines) + "\n\n"


def test_a_relations_file_scores_as_the_reference_poses_do(tmp_path):
    path = tmp_path / "toy.relations"
    path.write_text(_relations_text())
    relations = read_relations(path)
    np.testing.assert_array_equal(relations.lines, [2, 3, 4])
    metric = relations_metric(TIMES, ESTIMATE, relations, max_gap=0.01)
    assert metric == pytest.approx(relation_metric(ESTIMATE, REFERENCE, PAIRS), abs=1e-8)
    assert metric["trans_mean"] == pytest.approx(0.4 / 3)
    assert relations_metric(TIMES, REFERENCE, relations, max_gap=0.01)["trans_mean"] == pytest.approx(0, abs=1e-8)


def test_relation_times_take_the_nearest_pose_and_the_last_of_a_shared_time(tmp_path):
    # An odometry record at each scan's time before it (a wrong pose), and times off by 20 ms.
    times = np.array([9.9, 10.0, 10.0, 10.5, 10.5, 11.0])
    poses = np.array([[5.0, 5.0, 0.0], ESTIMATE[0], ESTIMATE[0], [7.0, 7.0, 1.0], ESTIMATE[1], ESTIMATE[2]])
    path = tmp_path / "toy.relations"
    path.write_text(_relations_text(times=TIMES + np.array([0.02, -0.02, 0.0])))
    relations = read_relations(path)
    np.testing.assert_array_equal(pairs_at_times(times, relations, max_gap=0.03), [[2, 4], [4, 5], [2, 5]])
    assert relations_metric(times, poses, relations, max_gap=0.03)["trans_mean"] == pytest.approx(0.4 / 3)
    with pytest.raises(
        InputError, match=r"toy.relations:2: no pose of the trajectory within 0.01 s of t = 10.020000 \(3 of 3"
    ):
        pairs_at_times(times, relations, max_gap=0.01)


def test_poses_without_a_clock_cannot_be_matched_by_time(tmp_path):
    path = tmp_path / "toy.relations"
    path.write_text(_relations_text())
    relations = read_relations(path)
    with pytest.raises(
        InputError, match=r"toy.relations:2: both times of the relation fall on one pose of run.csv \(3"
    ):
        pairs_at_times(np.zeros(3), relations, max_gap=20.0, source="run.csv")
    with pytest.raises(InputError, match="run.csv: the times decrease"):
        pairs_at_times(TIMES[::-1], relations, max_gap=0.01, source="run.csv")


def test_a_run_that_ended_early_is_named_as_such(tmp_path):
    path = tmp_path / "toy.relations"
    path.write_text(_relations_text() + "12.0 13.0 1 0 0 0 0 0\n")
    with pytest.raises(InputError, match=r"toy.relations:6: no pose of the trajectory within 0.05 s of t = 12.000000"):
        pairs_at_times(TIMES, read_relations(path), max_gap=0.05)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("1 2 0.5 0 0 0 0\n", r"bad.relations:1: a relation has 8 numbers .* got 7"),
        ("# header\n1 2 0.5 0 0 0 0 x\n", r"bad.relations:2: not a number"),
        ("1 2 nan 0 0 0 0 0\n", r"bad.relations:1: every value must be finite"),
        ("# nothing\n\n", r"bad.relations: no relations"),
        ("1 2 0.5 0 0 0 0 0\n0 0 0.5 0 0 0 0 0\n", r"bad.relations:2: a motion between two poses at one time"),
    ],
)
def test_a_broken_relations_file_names_the_file_and_line(tmp_path, text, message):
    path = tmp_path / "bad.relations"
    path.write_text(text)
    with pytest.raises(InputError, match=message):
        read_relations(path)


def test_the_relations_command_scores_a_run_folder_beside_a_reference(tmp_path):
    folder = tmp_path / "run"
    folder.mkdir()
    write_trajectory(folder / "best_trajectory.csv", TIMES, ESTIMATE, np.zeros((3, 3, 3)))
    write_trajectory(folder / "trajectory.csv", TIMES, REFERENCE, np.zeros((3, 3, 3)))  # the mean: not scored
    # A reference 1 cm off on pose 1 (along x: it changes relations (0, 1) and (1, 2) by 1 cm each).
    reference = REFERENCE + np.array([[0.0, 0.0, 0.0], [0.01, 0.0, 0.0], [0.0, 0.0, 0.0]])
    write_truth(tmp_path / "reference.truth.csv", TIMES, reference)
    (tmp_path / "toy.relations").write_text(_relations_text())
    result = CliRunner().invoke(
        main,
        [
            "relations",
            str(folder),
            str(tmp_path / "toy.relations"),
            "--reference",
            str(tmp_path / "reference.truth.csv"),
        ],
        catch_exceptions=False,
    )
    assert result.exit_code == 0, result.output
    lines = result.output.splitlines()
    assert "3 relations" in lines[0]
    assert "best_trajectory.csv: " in lines[1]
    assert f"translation {0.4 / 3:.4f} ± {np.std([0.2, 0.2, 0.0]):.4f} m" in lines[1]
    assert f"translation {0.02 / 3:.4f}" in lines[2]
    assert f"translation x{(0.4 / 3) / (0.02 / 3):.2f}" in lines[3]


def test_a_trajectory_scored_against_itself_as_reference(tmp_path):
    write_truth(tmp_path / "a.truth.csv", TIMES, ESTIMATE)
    (tmp_path / "toy.relations").write_text(_relations_text())
    truth = str(tmp_path / "a.truth.csv")
    result = CliRunner().invoke(
        main, ["relations", truth, str(tmp_path / "toy.relations"), "--reference", truth], catch_exceptions=False
    )
    assert result.exit_code == 0, result.output
    assert "trajectory over reference: translation x1.00, rotation x1.00" in result.output
