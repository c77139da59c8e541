"""What the fuzz suite found, each kept as its reproducer (issue 36). The envs' are in
test_env_actions_fuzz.py; the full disk's (simulate and the imports left a truncated log in place
of the last good one, with an error naming no file) in test_full_disk_fuzz.py.

Cases: 6."""

from __future__ import annotations

import math
import shutil

import numpy as np
import pytest
from cli_runs import cli
from fuzz_logs import mrclam_log

from mazeslam.data import log, sidecars
from mazeslam.data.mrclam import import_mrclam
from mazeslam.evaluation.sharpness import sharpness_lines, span_text


def shuffled_table(path, rows_reversed: bool) -> None:
    """The table ``path`` with its data rows reversed (out of time order), its comment kept."""
    lines = path.read_text().splitlines()
    path.write_text("\n".join([lines[0], *(lines[1:][::-1] if rows_reversed else lines[1:])]) + "\n")


@pytest.mark.parametrize("table", ["Robot1_Groundtruth.dat", "Robot1_Odometry.dat", "Robot1_Measurement.dat"])
def test_mrclam_rows_out_of_time_order_are_sorted_and_counted(tmp_path, table):
    """Were: reversed truth refused as "the truth spans t 2.750 to -1.000 s ... do not overlap";
    reversed odometry imported silently with wrong motion and a measurement left out."""
    in_order = mrclam_log(tmp_path / "a" / "robot.log", seed=3)
    dataset = tmp_path / "b" / "robot-dataset"
    shutil.copytree(in_order.parent / "robot-dataset", dataset)
    shuffled_table(dataset / table, rows_reversed=True)
    counts = import_mrclam(dataset, 1, tmp_path / "b" / "robot.log")
    rows = len((dataset / table).read_text().splitlines()) - 1
    assert counts["sorted"] == {table: rows - 1}  # reversed: every row but the first comes after a later one
    for name in ("robot.log", "robot.truth.csv"):
        assert (tmp_path / "b" / name).read_bytes() == (tmp_path / "a" / name).read_bytes()
    status, output = cli("import", "mrclam", dataset, "--robot", 1, "--out", tmp_path / "c.log")
    assert status == 0 and output.rstrip().endswith(f"; rows sorted into time order: {rows - 1} of {table}"), output


def test_an_mrclam_robot_that_sees_nothing_imports_without_a_warning(tmp_path):
    """Was: numpy's UserWarning "loadtxt: input contained no data" for an empty measurement table."""
    source = mrclam_log(tmp_path / "robot.log", seed=0)
    dataset = source.parent / "robot-dataset"
    (dataset / "Robot1_Measurement.dat").write_text("# time barcode range bearing\n")
    counts = import_mrclam(dataset, 1, tmp_path / "blind.log")
    course_log = log.read(tmp_path / "blind.log")
    assert counts["landmark_records"] == 0 and len(course_log) == counts["odometry_records"] == 5
    assert course_log.is_odometry.all()
    (dataset / "Robot1_Odometry.dat").write_text("# nothing\n")
    with pytest.raises(ValueError, match=r"Robot1_Odometry.dat: holds no data rows$"):
        import_mrclam(dataset, 1, tmp_path / "none.log")


def test_the_sharpness_heading_says_no_upper_range_in_words():
    """Was: "scan returns of 0.02-inf m" printed by ``mazeslam slam`` (corner FastSLAM's default
    [corners] max_range is unbounded)."""
    assert span_text(0.02, math.inf) == "from 0.02 m on"
    assert span_text(0.05, 0.4) == "of 0.05-0.4 m"
    assert sharpness_lines({}, 0.02, math.inf) == [
        "Map sharpness (scan returns from 0.02 m on placed along each path; dead reckoning leaves the glitches out):"
    ]


def test_imported_truth_of_a_sorted_dataset_is_unchanged(tmp_path):
    """The sort changes nothing in time order: the hand-made robot's truth is still its Vicon's."""
    path = mrclam_log(tmp_path / "robot.log", seed=1)
    times, poses = sidecars.read_truth(sidecars.truth_path(path))
    assert np.all(np.diff(times) >= 0)
    vicon = np.loadtxt(path.parent / "robot-dataset" / "Robot1_Groundtruth.dat")
    np.testing.assert_allclose(poses[:, 0], np.interp(times, vicon[:, 0], vicon[:, 1]), atol=1e-6)
