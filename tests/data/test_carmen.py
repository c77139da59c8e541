import gzip
import json

import numpy as np
import pytest
from conftest import PROJECT_ROOT, SHARED_DATA

from mazeslam.core.config import InputError
from mazeslam.data import sidecars
from mazeslam.data.carmen import front_laser, import_carmen, is_carmen, read_carmen
from mazeslam.data.loaded_run import load_run
from mazeslam.data.log import LogFormatError, read
from mazeslam.features.corners import CornerExtractor
from mazeslam.pipeline import load_slam_config

CARMEN = SHARED_DATA / "carmen"
LOGS = ["aces", "csail", "edmonton", "fhw", "freiburg-079", "freiburg-101", "orebro", "seattle"]
SAMPLE = """\
# message formats defined: PARAM SYNC ODOM FLASER
PARAM robot_front_laser_max 50 nohost 0
ODOM 0.0 0.0 0.0 0 0 0 10.0 nohost 10.0
FLASER 5 1.0 2.0 3.0 2.0 1.0 0.5 0.25 0.1 0.0 0.0 0.0 10.5 nohost 10.5
NEFF 1 2 3
ODOM 0.1 0.0 0.05 0 0 0 11.0 nohost 11.0
FLASER 5 1.5 2.5 3.5 2.5 1.5 0.6 0.25 0.2 0.1 0.0 0.05 11.5 nohost 11.5
"""


def test_read_hand_written_log(tmp_path):
    path = tmp_path / "tiny.log.gz"
    with gzip.open(path, "wt") as handle:
        handle.write(SAMPLE)
    assert is_carmen(path)
    log = read_carmen(path)
    np.testing.assert_allclose(log.ranges, [[1, 2, 3, 2, 1], [1.5, 2.5, 3.5, 2.5, 1.5]])
    np.testing.assert_allclose(log.scan_poses[1], [0.6, 0.25, 0.2])
    np.testing.assert_allclose(log.scan_odometry[1], [0.1, 0.0, 0.05])
    np.testing.assert_allclose(log.scan_times, [10.5, 11.5])
    np.testing.assert_allclose(log.odometry_poses[:, 2], [0.0, 0.05])
    assert log.max_range == 50.0
    assert log.ignored["NEFF"] == 1 and log.ignored["#"] == 1


def test_a_stated_maximum_range_passed_by_a_stray_reading_stands(tmp_path):
    scans = np.full((6, 181), 2.0)
    scans[3, 90] = 3.0  # one reading in 1086 beyond the PARAM's 2.5 m
    lines = [f"FLASER 181 {' '.join(map(str, scan))} 0 0 0 0 0 0 {k}.5 h {k}.5" for k, scan in enumerate(scans)]
    path = tmp_path / "stray.log"
    path.write_text("PARAM robot_front_laser_max 2.5 h 0\n" + "\n".join(lines) + "\n")
    assert read_carmen(path).max_range == 2.5


def test_a_passed_param_gives_way_to_the_robotlaser_maximum_range_before_the_largest_reading(tmp_path):
    path = tmp_path / "new.log"
    path.write_text("PARAM robot_front_laser_max 2.5 h 0\n" + ROBOTLASER_SAMPLE + "\n")
    assert read_carmen(path).max_range == 30.0  # the readings reach 3.5 m, within ROBOTLASER1's 30 m


def test_a_stated_maximum_range_the_readings_pass_gives_way_to_the_largest_reading(tmp_path):
    path = tmp_path / "short.log"
    path.write_text(SAMPLE.replace("robot_front_laser_max 50", "robot_front_laser_max 2.5"))
    assert read_carmen(path).max_range == 3.5  # the readings reach 3.5 m: 2.5 m is not the laser's limit
    import_carmen(path, tmp_path / "short_course.log")
    sensor = sidecars.read_map(sidecars.map_path(tmp_path / "short_course.log"))["sensor"]
    assert sensor["max_range"] == 3.5
    np.testing.assert_allclose(read(tmp_path / "short_course.log").scans, [[1, 2, 3, 2, 1], [1.5, 2.5, 0, 2.5, 1.5]])
    assert load_run(tmp_path / "short_course.log").sensor_max_range == 3.5  # what the grid filter clears to
    sidecar = tmp_path / "short_course.map.json"
    document = json.loads(sidecar.read_text())
    for bad in ("20", -1.0, [3.0]):
        sidecar.write_text(json.dumps({**document, "sensor": {**document["sensor"], "max_range": bad}}))
        with pytest.raises(InputError, match=r"short_course.map.json: sensor max_range must be a number >= 0"):
            _ = load_run(tmp_path / "short_course.log").sensor_max_range
    sidecar.unlink()
    assert load_run(tmp_path / "short_course.log").sensor_max_range == 0.0  # unknown without the sidecar


@pytest.mark.parametrize("beams, last_degrees", [(180, 89.0), (181, 90.0), (360, 89.5), (361, 90.0)])
def test_front_laser_geometry(beams, last_degrees):
    bearings = front_laser(beams).bearings(beams)
    assert bearings[0] == pytest.approx(-np.pi / 2) and np.degrees(bearings[-1]) == pytest.approx(last_degrees)
    assert np.degrees(bearings[1] - bearings[0]) == pytest.approx(1.0 if beams < 300 else 0.5)


def test_malformed_flaser_names_the_line(tmp_path):
    path = tmp_path / "bad.log"
    path.write_text("PARAM a 1 h 0\nFLASER 5 1.0 2.0 x 2.0 1.0 0 0 0 0 0 0 1.0 h 1.0\n")
    with pytest.raises(LogFormatError, match=r"bad.log:2: bad FLASER line"):
        read_carmen(path)
    path.write_text("ODOM 0 0 0 0 0 0 1.0 h 1.0\n")
    with pytest.raises(LogFormatError, match="no FLASER"):
        read_carmen(path)


def carmen_source(name):
    """The CARMEN log of building ``name``; skips the test without the shared data."""
    source = CARMEN / f"{name}-corrected.log.gz"
    if not source.exists():
        pytest.skip(f"CARMEN log not found at {source} (the shared data folder is absent)")
    return source


@pytest.mark.slow
@pytest.mark.parametrize("name", LOGS)
def test_corner_extraction_runs_on_every_scan_of_real_logs(name):
    log = read_carmen(carmen_source(name))
    params = load_slam_config(PROJECT_ROOT / "configs" / "carmen.toml").corners
    extractor = CornerExtractor(front_laser(log.n_beams), log.n_beams, params)
    lines = observations = 0
    for ranges in log.ranges:
        features = extractor.extract(ranges)
        lines += len(features.segments)
        observations += len(features.observations)
        for o in features.observations:
            assert np.isfinite([o.x, o.y, o.range, o.bearing]).all()
            assert np.all(np.linalg.eigvalsh(o.covariance_xy) > 0)
    assert lines > 2 * len(log.ranges)  # buildings: several walls in every scan on average
    assert observations > 0.5 * len(log.ranges)


ANCHORED = """\
ODOM 0 0 0 0 0 0 1.0 h 1.0
ODOM 0.1 0 0 0 0 0 1.5 h 1.5
FLASER 3 1.0 2.0 50.0 0.12 0.01 0.05 0.12 0.01 0.05 1.5 h 1.5
ODOM 0.12 0.01 0.05 0 0 0 0 h 1.5
ODOM 0.32 0.01 0.05 0 0 0 2.0 h 2.0
FLASER 3 1.5 2.5 3.5 0.3 0.02 0.05 0.3 0.02 0.05 2.0 h 2.0
"""


def import_text(tmp_path, name: str, lines: str) -> dict:
    """Import the CARMEN ``lines`` (a 50 m laser) to ``tmp_path / "<name>_course.log"``; the import's counts."""
    path = tmp_path / f"{name}.log"
    path.write_text("PARAM robot_front_laser_max 50 h 0\n" + lines)
    return import_carmen(path, tmp_path / f"{name}_course.log")


def test_import_follows_the_re_anchored_odometry(tmp_path):
    from mazeslam.data import log

    counts = import_text(tmp_path, "a", ANCHORED)
    assert counts["scans"] == 2 and counts["re-anchoring ODOM messages"] == 1
    course_log = log.read(tmp_path / "a_course.log")
    records = list(course_log.records())
    # 0.1 m of raw odometry before the first scan; after it, 0.2 m measured from the corrected pose
    # (0.12, 0.01): the jump from the raw 0.1 to the corrected 0.12 is a correction, not motion.
    odometry = [r for r in records if isinstance(r, log.OdometryRecord)]
    assert [round(r.distance, 6) for r in odometry] == [0.1, 0.2]
    scans = course_log.scans
    np.testing.assert_allclose(scans[0], [1.0, 2.0, 0.0])  # 50 m = the laser's maximum: no return
    _, reference = sidecars.read_truth(tmp_path / "a_course.truth.csv")
    np.testing.assert_allclose(reference[-1], [0.3, 0.02, 0.05])
    world = sidecars.read_map(tmp_path / "a_course.map.json")
    assert "reference" in world["truth_kind"] and world["sensor"]["first_beam_angle"] == pytest.approx(-np.pi / 2)


# Raw odometry before the first scan in its own frame: 1 m forward, then a quarter turn in place;
# the mapping run put that first scan at (5, 2) facing -x (its frame is turned by pi/2 from the odometry's).
RAW_BEFORE_THE_FIRST_SCAN = """\
ODOM 10 20 0 0 0 0 1.0 h 1.0
ODOM 11 20 0 0 0 0 1.5 h 1.5
ODOM 11 20 1.5707963267948966 0 0 0 1.7 h 1.7
FLASER 3 1.0 2.0 3.0 5 2 3.141592653589793 5 2 3.141592653589793 1.8 h 1.8
ODOM 5 2 3.141592653589793 0 0 0 0 h 1.8
ODOM 4 2 3.141592653589793 0 0 0 2.0 h 2.0
FLASER 3 1.0 2.0 3.0 4 2 3.141592653589793 4 2 3.141592653589793 2.1 h 2.1
"""


def test_the_reference_before_the_first_scan_is_moved_into_the_scans_frame(tmp_path):
    from mazeslam.core.motion import dead_reckoning

    counts = import_text(tmp_path, "turned", RAW_BEFORE_THE_FIRST_SCAN)
    assert counts["odometry records before the first scan"] == 2
    run = load_run(tmp_path / "turned_course.log")
    # Hand-computed: the scan at (5, 2, pi) came after 1 m forward and a quarter turn left, so the
    # robot started 1 m behind it along +y, facing pi - pi/2 = pi/2, and was at (5, 2, pi/2) after the 1 m.
    np.testing.assert_allclose(run.start_pose, [5.0, 1.0, np.pi / 2], atol=1e-12)
    truth = [[5, 2, np.pi / 2], [5, 2, np.pi], [5, 2, np.pi]]  # the sidecars keep 6 decimals
    np.testing.assert_allclose(run.truth[:3], truth, atol=1e-6)
    # Dead reckoning from the start reaches every record's reference pose (the odometry is exact here).
    np.testing.assert_allclose(dead_reckoning(run.log, run.start_pose), run.truth, atol=1e-5)


def test_imported_odometry_matches_the_reference_motion_between_scans(tmp_path):
    from mazeslam.core.geometry import relative
    from mazeslam.core.motion import dead_reckoning
    from mazeslam.data import log, sidecars

    course_log = log.read(imported("aces", tmp_path))
    _, reference = sidecars.read_truth(tmp_path / "aces.truth.csv")
    # Dead reckoning restarted at each scan's reference pose reaches the next scan close to it.
    scans = np.flatnonzero(course_log.is_scan)
    gaps = []
    for a, b in zip(scans[:-1], scans[1:]):
        stretch = dataclass_slice(course_log, a + 1, b + 1)
        end = dead_reckoning(stretch, reference[a])[-1]
        gaps.append(np.hypot(*relative(reference[b], end)[:2]))
    assert np.median(gaps) < 0.1  # metres, over intervals of about 0.7 m


def dataclass_slice(course_log, start, stop):
    from mazeslam.data.log import CourseLog

    return CourseLog(course_log.times[start:stop], course_log.flags[start:stop], course_log.values[start:stop])


def imported(name, tmp_path):
    """A CARMEN building imported as a course log (skips without the shared data)."""
    from mazeslam.data.carmen import import_carmen

    import_carmen(carmen_source(name), tmp_path / f"{name}.log")
    return tmp_path / f"{name}.log"


@pytest.mark.slow
@pytest.mark.parametrize("name, scans", [("freiburg-101", 150), ("orebro", 80)])
def test_laser_odometry_on_real_scans_beats_the_wheels(name, scans, tmp_path):
    """The first ``scans`` scans of a real building: laser odometry against the reference poses
    ends up well inside the wheel odometry's error (orebro's log has no wheel odometry at all)."""
    from mazeslam.core.motion import dead_reckoning
    from mazeslam.data.loaded_run import load_run
    from mazeslam.evaluation.metrics import absolute_trajectory_error
    from mazeslam.pipeline import load_slam_config
    from mazeslam.registration.scan_matching import laser_odometry

    path = imported(name, tmp_path)
    run = load_run(path)
    stop = np.flatnonzero(run.log.is_scan)[scans - 1] + 1
    course_log = dataclass_slice(run.log, 0, stop)
    reference = run.truth[:stop]
    start = run.start_pose
    matching = load_slam_config(PROJECT_ROOT / "configs" / "carmen.toml").scan_matching
    laser = laser_odometry(course_log, run.geometry, matching)
    at_scans = reference[laser.scan_records]
    wheels = absolute_trajectory_error(dead_reckoning(course_log, start)[laser.scan_records], at_scans)["rmse"]
    lasers = absolute_trajectory_error(laser.poses(start), at_scans)["rmse"]
    assert laser.accepted[1:].mean() > 0.9
    assert lasers < wheels / 3


def robotlaser(ranges, laser_pose, robot_pose, t, start=-np.pi / 2, resolution=np.pi / 4, remissions=()):
    """A ROBOTLASER1 line (the newer CARMEN laser message), written by hand."""
    fields = ["ROBOTLASER1", 0, start, resolution * (len(ranges) - 1), resolution, 30.0, 0.01, 0, len(ranges)]
    fields += list(ranges) + [len(remissions)] + list(remissions) + list(laser_pose) + list(robot_pose)
    fields += [0.0] * 5 + [t, "nohost", t]
    return " ".join(str(f) for f in fields)


ROBOTLASER_SAMPLE = "\n".join(
    [
        "ODOM 0.0 0.0 0.0 0 0 0 10.0 nohost 10.0",
        robotlaser([1, 2, 3, 2, 1], (0.1, 0.0, 0.0), (0.0, 0.0, 0.0), 10.5),
        "ODOM 0.1 0.0 0.05 0 0 0 11.0 nohost 11.0",
        robotlaser([1.5, 2.5, 3.5, 2.5, 1.5], (0.6, 0.25, 0.2), (0.5, 0.25, 0.2), 11.5, remissions=(0.3, 0.4)),
    ]
)


def test_read_robotlaser_lines(tmp_path):
    path = tmp_path / "new.log"
    path.write_text(ROBOTLASER_SAMPLE + "\n")
    assert is_carmen(path)
    log = read_carmen(path)
    np.testing.assert_allclose(log.ranges, [[1, 2, 3, 2, 1], [1.5, 2.5, 3.5, 2.5, 1.5]])
    np.testing.assert_allclose(log.scan_poses, [[0.1, 0.0, 0.0], [0.6, 0.25, 0.2]])  # the laser's pose
    np.testing.assert_allclose(log.scan_odometry[1], [0.5, 0.25, 0.2])  # the robot's
    np.testing.assert_allclose(log.scan_times, [10.5, 11.5])
    assert log.sequence == [("odom", 0), ("scan", 0), ("odom", 1), ("scan", 1)]
    np.testing.assert_allclose(np.degrees(log.beam_geometry.bearings(5)), [-90, -45, 0, 45, 90], atol=1e-9)
    assert log.max_range == 30.0


def test_flaser_lines_are_read_where_a_log_has_both(tmp_path):
    path = tmp_path / "both.log"
    path.write_text(SAMPLE + ROBOTLASER_SAMPLE + "\n")
    log = read_carmen(path)
    np.testing.assert_allclose(log.ranges[1], [1.5, 2.5, 3.5, 2.5, 1.5])
    np.testing.assert_allclose(log.scan_poses[1], [0.6, 0.25, 0.2])
    assert log.ignored["ROBOTLASER1"] == 2 and log.geometry is None and len(log.scan_times) == 2


def test_robotlaser_import_records_its_beams(tmp_path):
    path = tmp_path / "new.log"
    path.write_text(ROBOTLASER_SAMPLE.replace("-1.5707963267948966", "-0.7853981633974483") + "\n")
    import_carmen(path, tmp_path / "new_course.log")
    sensor = sidecars.read_map(sidecars.map_path(tmp_path / "new_course.log"))["sensor"]
    bearings = sidecars.beam_geometry(sensor).bearings(5)
    np.testing.assert_allclose(np.degrees(bearings), [-45, 0, 45, 90, 135], atol=1e-9)
    assert sensor["max_range"] == 30.0


@pytest.mark.parametrize(
    ("line", "message"),
    [
        (
            robotlaser([1, 2, 3, 2, 1], (0, 0, 0), (0, 0, 0), 12.0, start=-1.0),
            r"bad.log:3: bad ROBOTLASER1 line: its beams",
        ),
        (
            robotlaser([1, 2, 3, 2, 1], (0, 0, 0), (0, 0, 0), 12.0).rsplit(" ", 8)[0],
            r"bad.log:3: bad ROBOTLASER1 line: .*needs",
        ),
    ],
)
def test_malformed_robotlaser_names_the_line(tmp_path, line, message):
    path = tmp_path / "bad.log"
    path.write_text("\n".join(ROBOTLASER_SAMPLE.splitlines()[:2] + [line]) + "\n")
    with pytest.raises(LogFormatError, match=message):
        read_carmen(path)


def test_import_onto_its_own_input_is_refused_and_the_input_kept(tmp_path):
    """Issue 36 item 7: `mazeslam import carmen runs/aces.log --out runs/aces.log` overwrote its
    input and exited 0."""
    path = tmp_path / "aces.log"
    path.write_text(SAMPLE)
    for out in (path, tmp_path / "other" / ".." / "aces.log"):
        with pytest.raises(ValueError, match="is the input file.*: writing there would overwrite or replace it"):
            import_carmen(path, out)
    assert path.read_text() == SAMPLE
    truth_named = tmp_path / "run.truth.csv"  # an input where the import would put a sidecar
    truth_named.write_text(SAMPLE)
    with pytest.raises(ValueError, match="run.truth.csv: is the input file"):
        import_carmen(truth_named, tmp_path / "run.log")
    assert truth_named.read_text() == SAMPLE and not (tmp_path / "run.log").exists()


def test_a_byte_order_mark_before_the_first_line_is_dropped(tmp_path):
    path = tmp_path / "bom.log"
    path.write_bytes(b"\xef\xbb\xbf" + SAMPLE.encode())
    carmen = read_carmen(path)
    assert carmen.params == read_carmen(_plain(tmp_path, SAMPLE)).params == {"robot_front_laser_max": "50"}
    assert "\ufeff#" not in carmen.ignored


def _plain(folder, text):
    path = folder / "plain.log"
    path.write_text(text)
    return path
