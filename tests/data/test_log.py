import numpy as np
import pytest

from mazeslam.data import log

GOOD = """\
0.1 0 0.000000 0.000000 -1 -1
0.3 0 0.010000 -0.020000 -1 -1
0.3 1 0.5 0.0 0.25 1.125
0.5 0 0.010000 0.000000 -1 -1
"""


def test_parse_hand_written_log():
    course_log = log.parse(GOOD, "good.log")
    assert len(course_log) == 4
    assert course_log.n_beams == 4
    np.testing.assert_allclose(course_log.odometry, [[0, 0], [0.01, -0.02], [0.01, 0]])
    np.testing.assert_allclose(course_log.scans, [[0.5, 0.0, 0.25, 1.125]])
    records = list(course_log.records())
    assert isinstance(records[2], log.ScanRecord) and records[2].t == 0.3
    assert records[1] == log.OdometryRecord(1, 0.3, 0.01, -0.02)
    assert course_log.line_numbers.tolist() == [1, 2, 3, 4]


def test_commas_comments_and_blank_lines():
    text = "# a header\n\n" + GOOD.replace(" ", ",") + "% trailing comment\n"
    course_log = log.parse(text)
    np.testing.assert_array_equal(course_log.values, log.parse(GOOD).values)
    assert course_log.line_numbers.tolist() == [3, 4, 5, 6]


def test_write_then_read_is_lossless_at_the_written_precision(tmp_path):
    rng = np.random.default_rng(0)
    path = tmp_path / "run.log"
    times = np.cumsum(rng.uniform(0.01, 0.3, 40))
    with log.LogWriter(path, beams=7) as writer:
        for t in times:
            if rng.random() < 0.5:
                writer.write_odometry(t, rng.normal(0, 0.01), rng.normal(0, 0.05))
            else:
                writer.write_scan(t, np.where(rng.random(7) < 0.2, 0.0, rng.uniform(0.05, 1.7, 7)))
    first = log.read(path)
    np.testing.assert_allclose(first.times, times, atol=5e-7)
    log.write(tmp_path / "again.log", first)
    assert (tmp_path / "again.log").read_bytes() == path.read_bytes()


def test_writer_flushes_every_record(tmp_path):
    path = tmp_path / "live.log"
    writer = log.LogWriter(path, beams=3)
    writer.write_odometry(0.1, 0.01, 0.0)
    writer.write_scan(0.2, [0.1, 0.2, 0.0])
    assert len(log.read(path)) == 2  # readable while still open
    writer.close()


def test_writer_refuses_bad_records(tmp_path):
    with log.LogWriter(tmp_path / "w.log", beams=3) as writer:
        writer.write_odometry(1.0, 0.0, 0.0)
        with pytest.raises(ValueError, match="earlier"):
            writer.write_odometry(0.5, 0.0, 0.0)
        with pytest.raises(ValueError, match="ranges"):
            writer.write_scan(2.0, [0.1, 0.2])
        with pytest.raises(ValueError, match=">= 0"):
            writer.write_scan(2.0, [0.1, -0.2, 0.3])


@pytest.mark.parametrize(
    "bad_line, line_number, reason",
    [
        ("0.2 1 0.5 0.1 0.2", 3, "has 5 values, expected 6"),
        ("0.2 1 0.5 abc 0.2 0.3", 3, "value 'abc' in column 4 is not a number"),
        ("0.2 1 0.5 nan 0.2 0.3", 3, "column 4 is not finite"),
        ("0.2 3 0.5 0.1 0.2 0.3", 3, "flag 3 is not 0 (odometry), 1 (scan) or 2 (landmark)"),
        ("0.05 1 0.5 0.1 0.2 0.3", 3, "timestamp 0.05 is earlier than the previous record's 0.100000"),
        ("0.2 0 0.01 0.0 0 0", 3, "not padded with -1 after dX and dTheta (column 5 is 0)"),
        ("0.2 1 0.5 -0.1 0.2 0.3", 3, "negative range -0.1 in column 4"),
        ("0.2 1 0.5 # 0.2 0.3", 3, "value '#' in column 4 is not a number"),  # a comment starts a line only
    ],
)
def test_bad_input_names_file_line_and_reason(tmp_path, bad_line, line_number, reason):
    text = "0.0 0 0 0 -1 -1\n0.1 1 0.5 0.5 0.5 0.5\n" + bad_line + "\n0.3 0 0 0 -1 -1\n"
    path = tmp_path / "bad.log"
    path.write_text(text)
    with pytest.raises(log.LogFormatError) as error:
        log.read(path)
    assert error.value.line == line_number
    assert str(error.value) == f"{path}:{line_number}: {error.value.reason}"
    assert reason in error.value.reason


def test_the_table_at_once_and_line_by_line_read_alike():
    text = GOOD.replace("0.5 1.125", "5e-1 1_125e-3")  # both spellings Python's float reads
    fast = log.parse(text)
    rows = [(number, line.split()) for number, line in enumerate(text.splitlines(), start=1)]
    slow = log._parse_line_by_line(rows, "<text>", strict=True)
    np.testing.assert_array_equal(fast.values, slow.values)
    np.testing.assert_array_equal(fast.line_numbers, slow.line_numbers)


def test_lenient_reading_reports_skipped_lines():
    text = "0.0 0 0 0 -1 -1\n0.1 1 0.5 0.5 0.5\n0.2 7 0 0 -1 -1\n0.3 1 0.5 0.5 0.5 0.5\n"
    course_log = log.parse(text, "x.log", strict=False)
    assert len(course_log) == 2
    assert [(s.line, s.reason.split()[0]) for s in course_log.skipped] == [(2, "has"), (3, "flag")]
    assert course_log.line_numbers.tolist() == [1, 4]


def test_empty_and_missing_logs(tmp_path):
    with pytest.raises(log.LogFormatError, match="no records"):
        log.parse("# only a comment\n\n", "e.log")
    with pytest.raises(FileNotFoundError, match="not found"):
        log.read(tmp_path / "missing.log")


def test_summary_of_hand_written_log():
    facts = log.summary(log.parse(GOOD))
    assert facts["records"] == 4 and facts["scan_records"] == 1 and facts["beams"] == 4
    assert facts["distance_m"] == pytest.approx(0.02)
    assert facts["total_rotation_rad"] == pytest.approx(0.02)
    assert facts["no_return_fraction"] == pytest.approx(0.25)


def test_reads_the_exercise_robot_log(course_log_path):
    course_log = log.read(course_log_path)
    facts = log.summary(course_log)
    assert (facts["records"], facts["odometry_records"], facts["scan_records"], facts["beams"]) == (198, 146, 52, 360)
    assert facts["duration_s"] == pytest.approx(37.4, abs=0.1)
    assert 0.05 < facts["no_return_fraction"] < 0.15  # the README: about 10 % of beams


def test_landmark_records_round_trip(tmp_path):
    path = tmp_path / "lm.log"
    with log.LogWriter(path, beams=3) as writer:
        writer.write_odometry(0.1, 0.02, 0.01)
        writer.write_landmark(0.1, 7, 2.5, -0.3)
        writer.write_landmark(0.1, -1, 1.25, 0.5)
    course_log = log.read(path)
    records = list(course_log.records())
    assert records[1] == log.LandmarkRecord(1, 0.1, 7, 2.5, -0.3)
    assert records[2].landmark == -1
    assert course_log.n_beams is None and log.summary(course_log)["landmark_records"] == 2
    log.write(tmp_path / "again.log", course_log)
    assert (tmp_path / "again.log").read_bytes() == path.read_bytes()


@pytest.mark.parametrize(
    "line, reason",
    [
        ("0.2 2 1.5 1.0 0.1", "landmark id 1.5 is not an integer"),
        ("0.2 2 3 0 0.1", "landmark range 0 is not positive"),
        ("0.2 2 3 1.0 0.1 7", None),
    ],
)
def test_bad_landmark_records(line, reason):
    width = len(line.split())
    text = "0.0 0 0 0" + " -1" * (width - 4) + "\n" + line + "\n"
    with pytest.raises(log.LogFormatError) as error:
        log.parse(text, "lm.log")
    assert (reason or "not padded with -1 after id, range and bearing") in str(error.value)


def test_a_utf8_byte_order_mark_is_dropped(tmp_path):
    """Issue 36 item 11: a log saved by an editor that writes a BOM read as the same log (the BOM
    once showed as ``'\\ufeff0.200000' is not a number``)."""
    path = tmp_path / "bom.log"
    path.write_bytes(b"\xef\xbb\xbf" + GOOD.encode())
    for strict in (True, False):
        course_log = log.read(path, strict=strict)
        np.testing.assert_array_equal(course_log.values, log.parse(GOOD).values)
        assert course_log.line_numbers.tolist() == [1, 2, 3, 4] and not course_log.skipped


LANDMARK_IN_SCANS = GOOD + "0.5 2 3 0.2 0.1 -1\n0.7 1 0.5 0.5 0.5 0.5\n"


def test_a_landmark_record_in_a_log_of_scans_is_a_bad_line():
    """Issue 36 item 11: a landmark record inside a scan log once gave a NaN trajectory; no filter,
    smoother or calibration weighs the two kinds together, so the log is refused at its line."""
    with pytest.raises(log.LogFormatError) as error:
        log.parse(LANDMARK_IN_SCANS, "mixed.log")
    assert str(error.value) == (
        "mixed.log:5: a landmark observation (flag 2) in a log of 2 scans (1 such line): "
        "a log holds scans or landmark observations, not both"
    )
    lenient = log.parse(LANDMARK_IN_SCANS, "mixed.log", strict=False)
    assert not lenient.is_landmark.any() and lenient.is_scan.sum() == 2
    assert lenient.line_numbers.tolist() == [1, 2, 3, 4, 6]
    assert [(skip.line, skip.reason.split(":")[0]) for skip in lenient.skipped] == [
        (5, "a landmark observation (flag 2) in a log of 2 scans (1 such line)")
    ]


def test_a_scan_in_a_log_of_landmark_observations_is_the_bad_line():
    text = "0.1 0 0.01 0.0 -1\n0.1 2 3 1.5 0.1\n0.2 2 4 1.5 0.2\n0.3 1 0.5 0.5 0.5\n"
    with pytest.raises(log.LogFormatError, match=r"landmarks.log:4: a scan \(flag 1\) in a log of 2 landmark"):
        log.parse(text, "landmarks.log")
    # Read line by line (a bad value elsewhere): leniently, both bad lines are left out.
    lenient = log.parse(text + "0.4 0 0.01 abc -1\n", "landmarks.log", strict=False)
    assert [skip.line for skip in lenient.skipped] == [4, 5] and lenient.is_landmark.sum() == 2
    assert "a scan (flag 1) in a log of 2 landmark observations" in lenient.skipped[0].reason


def test_an_output_that_is_an_input_is_refused(tmp_path):
    source = tmp_path / "in.log"
    source.write_text(GOOD)
    with pytest.raises(ValueError, match="in.log: is the input file: writing there would overwrite or replace it"):
        log.refuse_to_overwrite([source], [tmp_path / "out.log", source])
    with pytest.raises(ValueError, match=f"is the input file {source}"):
        log.refuse_to_overwrite([source], [tmp_path / "sub" / ".." / "in.log"])
    link = tmp_path / "link.log"
    link.symlink_to(source)
    with pytest.raises(ValueError, match="link.log: is the input file"):
        log.refuse_to_overwrite([source], [link])
    with pytest.raises(ValueError, match="is the input file"):  # one that does not exist yet is replaced
        log.refuse_to_overwrite([tmp_path / "missing.dat"], [tmp_path / "missing.dat"])
    log.refuse_to_overwrite([source], [tmp_path / "out.log"])
    assert source.read_text() == GOOD
