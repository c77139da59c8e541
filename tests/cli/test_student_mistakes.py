"""Issue 35, "also met": a student's typical mistakes get one line that says what to do, and a
failed first run leaves nothing behind."""

from cli_runs import cli

from mazeslam.data import log

#: Three lines of a CARMEN log (the format `mazeslam import carmen` reads).
CARMEN_LINES = (
    "PARAM robot_front_laser_max 50 h 0\nODOM 0.0 0.0 0.0 0 0 0 1.0 h 1.0\nFLASER 3 1.5 2.5 3.5 0 0 0 0 0 0 1.5 h 1.5\n"
)


def test_a_carmen_file_given_to_slam_or_info_is_named_as_one_with_the_import_to_run(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    source = tmp_path / "aces-corrected.log"
    source.write_text(CARMEN_LINES)
    for command in ("slam", "info"):
        status, output = cli(command, source)
        assert status == 2
        assert output.strip().splitlines() == [
            f"error: {source}: not a course log (a CARMEN log? run `mazeslam import carmen {source} "
            "--out runs/aces-corrected.log`, then give that log)"
        ]
    assert not (tmp_path / "runs").exists()  # the failed slam left no runs/aces-corrected/slam/


def test_a_failed_first_slam_leaves_no_empty_output_folder(tmp_path, monkeypatch):
    """A log of landmark observations without a sidecar runs the defaults, which refuse it (no
    observation noise): the error, and no runs/<name>/slam/ made for nothing."""
    monkeypatch.chdir(tmp_path)
    path = tmp_path / "seen.log"
    with log.LogWriter(path, 3) as writer:
        writer.write_odometry(0.0, 0.0, 0.0)
        writer.write_landmark(0.5, 6, 1.0, 0.1)
    status, output = cli("slam", path, "--quiet")
    assert status == 2 and "error: " in output and "configs/mrclam.toml" in output
    assert not (tmp_path / "runs").exists()
    (tmp_path / "runs").mkdir()  # a folder that was there before stays
    assert cli("slam", path, "--quiet")[0] == 2
    assert (tmp_path / "runs").is_dir() and not any((tmp_path / "runs").iterdir())


def test_report_on_a_folder_that_is_not_a_sweeps_says_so_in_one_line(tmp_path):
    status, output = cli("report", tmp_path)
    assert status == 2
    assert output.strip().splitlines() == [
        f"error: {tmp_path}: not a sweep's results folder (no sweep.json or results.csv); "
        f"`mazeslam sweep configs/sweeps/smoke.toml --out {tmp_path}` makes one"
    ]


def test_record_script_help_gives_the_units():
    status, output = cli("record", "--help")
    text = " ".join(output.split())
    assert status == 0 and "seconds, forward speed in m/s, turn rate in rad/s" in text


def test_the_beam_geometry_line_reads_as_english(course_log_path, tmp_path):
    status, output = cli("slam", course_log_path, "--quiet", "--particles", 3, "--out", tmp_path / "out")
    assert status == 0, output
    assert "beam geometry: detected from the scans: beam 0 at 0 deg" in output
    assert "from detected" not in output
