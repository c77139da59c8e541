"""Import of the UTIAS MRCLAM data and FastSLAM on it against Vicon ground truth."""

import dataclasses
import gzip

import numpy as np
import pytest
from conftest import PROJECT_ROOT, SHARED_DATA

from mazeslam.core.motion import dead_reckoning
from mazeslam.data import log, sidecars
from mazeslam.data.mrclam import import_mrclam
from mazeslam.evaluation.metrics import absolute_trajectory_error, normalized_estimation_error
from mazeslam.pipeline import load_slam_config, slam_on_file

DATASET = SHARED_DATA / "mrclam" / "MRCLAM_Dataset6"


def write(folder, name, rows):
    with gzip.open(folder / f"{name}.gz", "wt") as handle:
        handle.write("# header\n" + "\n".join(" ".join(str(v) for v in row) for row in rows) + "\n")


def test_import_of_a_hand_made_dataset(tmp_path):
    # A robot driving at 0.1 m/s, turning at 0.2 rad/s, for 2 s; it sees landmark 6 once and robot 2 once.
    write(tmp_path, "Robot1_Odometry.dat", [(t, 0.1, 0.2) for t in np.arange(0, 2.01, 0.5)])
    write(tmp_path, "Robot1_Measurement.dat", [(0.75, 30, 1.5, 0.1), (1.0, 14, 2.0, 0.2)])
    write(tmp_path, "Robot1_Groundtruth.dat", [(t, 0.1 * t, 0.0, 0.2 * t) for t in np.arange(-1, 3, 0.25)])
    write(tmp_path, "Landmark_Groundtruth.dat", [(6, 3.0, 4.0, 0.001, 0.001)])
    write(tmp_path, "Barcodes.dat", [(1, 5), (2, 14), (6, 30)])
    counts = import_mrclam(tmp_path, 1, tmp_path / "r.log")
    assert counts["landmark_records"] == 1 and counts["skipped"] == {"another robot": 1}
    course_log = log.read(tmp_path / "r.log")
    records = list(course_log.records())
    landmark = next(r for r in records if isinstance(r, log.LandmarkRecord))
    assert (landmark.t, landmark.landmark, landmark.range, landmark.bearing) == (0.75, 6, 1.5, 0.1)
    # An odometry record right before the measurement integrates exactly up to it.
    before = records[landmark.index - 1]
    assert isinstance(before, log.OdometryRecord) and before.t == 0.75
    np.testing.assert_allclose(course_log.odometry.sum(axis=0), [0.2, 0.4], atol=1e-6)
    _, truth = sidecars.read_truth(tmp_path / "r.truth.csv")
    np.testing.assert_allclose(truth[landmark.index], [0.075, 0.0, 0.15], atol=1e-6)
    world = sidecars.read_map(tmp_path / "r.map.json")
    assert world["landmark_ids"] == [6]
    np.testing.assert_allclose(world["corners"], [[3.0, 4.0]])


def test_missing_file_is_named(tmp_path):
    with pytest.raises(FileNotFoundError, match="Robot1_Odometry.dat"):
        import_mrclam(tmp_path, 1, tmp_path / "r.log")


@pytest.fixture(scope="module")
def robot1(tmp_path_factory):
    if not DATASET.exists():
        pytest.skip(f"MRCLAM data not found at {DATASET} (the shared data folder is absent)")
    out = tmp_path_factory.mktemp("mrclam") / "robot1.log"
    import_mrclam(DATASET, 1, out)
    return out


@pytest.mark.slow
@pytest.mark.parametrize("association", ["known", "unknown"])
def test_fastslam_halves_the_odometry_error_on_real_data_and_its_covariance_covers_it(robot1, association):
    config = load_slam_config(PROJECT_ROOT / "configs" / "mrclam.toml")
    config = dataclasses.replace(config, fastslam=dataclasses.replace(config.fastslam, association=association))
    result = slam_on_file(robot1, config, progress=False)
    _, truth = sidecars.read_truth(sidecars.truth_path(robot1))
    world = sidecars.read_map(sidecars.map_path(robot1))
    reckoned = dead_reckoning(log.read(robot1), world["start_pose"])
    for align in (False, True):
        slam_error = absolute_trajectory_error(result.mean_poses, truth, align=align)["rmse"]
        odometry_error = absolute_trajectory_error(reckoned, truth, align=align)["rmse"]
        assert slam_error <= 0.5 * odometry_error, (align, slam_error, odometry_error)
    nees = normalized_estimation_error(result.mean_poses, result.pose_covariances, truth)
    assert np.nanmedian(nees) < 20  # the bar: overconfident by at most about 2.6 in standard deviation


def hand_made_dataset(folder, truth_times=None):
    """``test_import_of_a_hand_made_dataset``'s robot, its truth at ``truth_times`` (default: every
    0.25 s from -1 to 2.75 s, around the whole run)."""
    truth_times = np.arange(-1, 3, 0.25) if truth_times is None else truth_times
    write(folder, "Robot1_Odometry.dat", [(t, 0.1, 0.2) for t in np.arange(0, 2.01, 0.5)])
    write(folder, "Robot1_Measurement.dat", [(0.75, 30, 1.5, 0.1)])
    write(folder, "Robot1_Groundtruth.dat", [(t, 0.1 * t, 0.0, 0.2 * t) for t in truth_times])
    write(folder, "Landmark_Groundtruth.dat", [(6, 3.0, 4.0, 0.001, 0.001)])
    write(folder, "Barcodes.dat", [(1, 5), (2, 14), (6, 30)])
    return folder


def test_truth_that_does_not_overlap_the_odometry_is_refused(tmp_path):
    """Issue 36 item 11: such truth was imported as one constant pose (the nearer end's)."""
    hand_made_dataset(tmp_path, truth_times=np.arange(100, 103, 0.25))
    with pytest.raises(ValueError) as error:
        import_mrclam(tmp_path, 1, tmp_path / "r.log")
    assert str(error.value) == (
        f"{tmp_path / 'Robot1_Groundtruth.dat.gz'}: the truth spans t 100.000 to 102.750 s and the odometry "
        "t 0.000 to 2.000 s: they do not overlap, so no record would get a true pose (files of different runs?)"
    )
    assert not (tmp_path / "r.log").exists()


def test_records_outside_a_partly_overlapping_truth_are_counted(tmp_path):
    hand_made_dataset(tmp_path, truth_times=np.arange(0, 1.01, 0.25))  # truth ends at 1 s of 2
    counts = import_mrclam(tmp_path, 1, tmp_path / "r.log")
    record_times = log.read(tmp_path / "r.log").times
    assert counts["outside_truth"] == int(np.sum(record_times > 1.0)) == 2
    _, truth = sidecars.read_truth(tmp_path / "r.truth.csv")
    np.testing.assert_allclose(truth[-1], [0.1, 0.0, 0.2])  # held at the truth's end


def test_import_onto_a_dataset_file_is_refused(tmp_path):
    """Issue 36 item 7, for MRCLAM: an output that is one of the tables it reads, or a plain ``.dat``
    that would shadow the ``.dat.gz`` read (the next import would read the log as the table)."""
    hand_made_dataset(tmp_path)
    before = {path.name: path.read_bytes() for path in tmp_path.iterdir()}
    for out in ("Robot1_Odometry.dat.gz", "Barcodes.dat", "Robot1_Groundtruth.dat"):
        with pytest.raises(ValueError, match=f"{out}: is the input file"):
            import_mrclam(tmp_path, 1, tmp_path / out)
    assert {path.name: path.read_bytes() for path in tmp_path.iterdir()} == before


def test_a_byte_order_mark_in_a_table_is_dropped(tmp_path):
    hand_made_dataset(tmp_path)
    barcodes = tmp_path / "Barcodes.dat.gz"
    barcodes.write_bytes(gzip.compress(b"\xef\xbb\xbf" + gzip.decompress(barcodes.read_bytes())))
    assert import_mrclam(tmp_path, 1, tmp_path / "r.log")["landmark_records"] == 1
