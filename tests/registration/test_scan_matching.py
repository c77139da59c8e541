"""Laser odometry against analytic scans: rays cast from known poses at known walls."""

import math

import numpy as np
import pytest

from mazeslam.core.beams import BeamGeometry
from mazeslam.core.geometry import advance_pose, compose, relative, wrap_angle
from mazeslam.data.log import ODOMETRY, SCAN, CourseLog
from mazeslam.registration.correlative import CorrelativeParams, LikelihoodGrid, correlative_candidates
from mazeslam.registration.scan_matching import (
    ReferenceScan,
    ScanMatchParams,
    laser_odometry,
    match_scan,
    scan_points,
    wheel_motion,
)
from mazeslam.sim.laser import cast_rays

#: A front laser like the CARMEN logs': 181 beams over 180 degrees.
FRONT_LASER = BeamGeometry(first_beam_angle=-math.pi / 2, direction=1, field_of_view=math.pi)
BEAMS = 181
MAX_RANGE = 8.0

#: A 12 x 8 m room with a partition and a pillar (walls x1, y1, x2, y2 in metres): no direction is
#: unconstrained from anywhere inside it.
ROOM = np.array(
    [
        [0, 0, 12, 0],
        [12, 0, 12, 8],
        [12, 8, 0, 8],
        [0, 8, 0, 0],
        [5, 0, 5, 3],
        [5, 3, 7, 3],
        [8, 5, 9, 5],
        [9, 5, 9, 6],
        [9, 6, 8, 6],
        [8, 6, 8, 5],
    ],
    dtype=float,
)

#: Two parallel walls 2 m apart and 100 m long: from inside, the laser cannot see how far along it.
CORRIDOR = np.array([[-50, 0, 50, 0], [-50, 2, 50, 2]], dtype=float)


def scan_from(pose, walls, noise=0.0, rng=None):
    """Ranges (BEAMS,) of the front laser at robot ``pose`` among ``walls``; 0 = no return."""
    angles = pose[2] + FRONT_LASER.bearings(BEAMS)
    ranges = cast_rays(pose[:2], angles, walls, MAX_RANGE)
    if noise:
        ranges = ranges + rng.normal(0.0, noise, BEAMS)
    return np.where(np.isfinite(ranges), ranges, 0.0)


def scans_only_log(poses, walls, odometry=False):
    """A course log with one scan per pose, and (optionally) the true motion as an odometry record
    before each scan after the first."""
    times, flags, rows = [], [], []
    for index, pose in enumerate(poses):
        if odometry and index:
            step = relative(poses[index - 1], pose)
            distance = math.copysign(math.hypot(step[0], step[1]), step[0])
            times.append(index - 0.5), flags.append(ODOMETRY), rows.append([distance, step[2]] + [-1.0] * (BEAMS - 2))
        times.append(float(index)), flags.append(SCAN), rows.append(list(scan_from(pose, walls)))
    return CourseLog(np.array(times), np.array(flags), np.array(rows))


def test_match_recovers_a_known_motion_from_a_wrong_prior():
    params = ScanMatchParams()
    first = np.array([2.0, 2.0, 0.3])
    motion = np.array([0.8, 0.1, 0.25])
    second = compose(first, motion)
    reference = ReferenceScan(scan_points(scan_from(first, ROOM), FRONT_LASER, params), params)
    points = scan_points(scan_from(second, ROOM), FRONT_LASER, params)
    prior = motion + np.array([0.1, -0.08, 0.05])
    match = match_scan(reference, points, prior, np.diag([0.2**2, 0.2**2, 0.1**2]), params)
    assert np.hypot(*(match.pose[:2] - motion[:2])) < 0.005
    assert abs(wrap_angle(match.pose[2] - motion[2])) < 0.002
    assert match.overlap > 0.8  # the rest is wall the first pose did not see


def test_match_with_range_noise_stays_within_the_noise():
    rng = np.random.default_rng(3)
    params = ScanMatchParams()
    first, motion = np.array([9.5, 2.0, 2.0]), np.array([1.0, -0.05, -0.3])
    reference = ReferenceScan(scan_points(scan_from(first, ROOM, 0.01, rng), FRONT_LASER, params), params)
    points = scan_points(scan_from(compose(first, motion), ROOM, 0.01, rng), FRONT_LASER, params)
    match = match_scan(reference, points, motion + [0.05, 0.05, 0.03], np.diag([0.1**2, 0.1**2, 0.1**2]), params)
    assert np.hypot(*(match.pose[:2] - motion[:2])) < 0.03
    assert abs(wrap_angle(match.pose[2] - motion[2])) < 0.01


def test_corridor_leaves_the_along_track_motion_to_the_prior():
    """The points fix the motion across the corridor and the turn; along it only the prior can."""
    params = ScanMatchParams()
    first, motion = np.array([0.0, 1.0, 0.0]), np.array([1.0, 0.05, 0.02])
    reference = ReferenceScan(scan_points(scan_from(first, CORRIDOR), FRONT_LASER, params), params)
    points = scan_points(
        scan_from(
            compose(first, motion),
            CORRIDOR,
        ),
        FRONT_LASER,
        params,
    )
    prior = np.array([1.3, 0.0, 0.0])
    match = match_scan(reference, points, prior, np.diag([0.05**2, 0.05**2, 0.05**2]), params)
    assert match.pose[0] == pytest.approx(1.3, abs=0.01)
    assert match.pose[1] == pytest.approx(0.05, abs=0.01)
    assert match.pose[2] == pytest.approx(0.02, abs=0.003)


def test_correlative_search_finds_a_large_motion_without_a_prior_mean():
    params = ScanMatchParams()
    first, motion = np.array([2.0, 4.0, -0.2]), np.array([1.2, -0.4, 0.7])
    reference_points = scan_points(scan_from(first, ROOM), FRONT_LASER, params)
    points = scan_points(scan_from(compose(first, motion), ROOM), FRONT_LASER, params)
    grid = LikelihoodGrid(reference_points, params.correlative)
    broad = np.diag([1.0, 1.0, 0.7**2])
    candidates = correlative_candidates(grid, points, np.zeros(3), broad, params.correlative)
    assert len(candidates) == params.correlative.candidates
    nearest = min(candidates, key=lambda pose: np.hypot(*(pose[:2] - motion[:2])))
    assert np.hypot(*(nearest[:2] - motion[:2])) <= 2 * params.correlative.resolution
    assert abs(wrap_angle(nearest[2] - motion[2])) <= math.radians(2 * params.correlative.turn_step)


def test_candidates_are_one_per_basin():
    params = CorrelativeParams(candidates=4)
    scan_params = ScanMatchParams()
    points = scan_points(scan_from(np.array([3.0, 5.0, 0.0]), ROOM), FRONT_LASER, scan_params)
    candidates = correlative_candidates(LikelihoodGrid(points, params), points, np.zeros(3), np.eye(3), params)
    for i in range(len(candidates)):
        for j in range(i):
            apart = np.hypot(*(candidates[i, :2] - candidates[j, :2])) > 2 * params.resolution
            turned = abs(wrap_angle(candidates[i, 2] - candidates[j, 2])) > math.radians(2 * params.turn_step)
            assert apart or turned


def test_laser_odometry_of_a_log_without_odometry_recovers_the_path():
    path = [np.array([1.0, 1.5, 0.2])]
    for step in ([1.0, 0.1, 0.3], [1.1, -0.2, 0.5], [0.9, 0.0, -0.6], [1.0, 0.3, 0.9], [0.8, 0.0, 0.0]):
        path.append(compose(path[-1], step))
    course_log = scans_only_log(path, ROOM)
    result = laser_odometry(course_log, FRONT_LASER, ScanMatchParams())
    true_steps = np.array([relative(a, b) for a, b in zip(path[:-1], path[1:])])
    assert not result.had_odometry.any()
    assert result.accepted[1:].all()
    assert np.abs(result.increments[0]).max() == 0.0  # nothing moves before the first scan
    assert np.abs(result.increments[1:, :2] - true_steps[:, :2]).max() < 0.01
    assert np.abs(wrap_angle(result.increments[1:, 2] - true_steps[:, 2])).max() < 0.005
    chained = result.poses(path[0])
    assert np.hypot(*(chained[-1, :2] - path[-1][:2])) < 0.03


def test_laser_odometry_reads_the_odometry_between_scans():
    path = [np.array([1.0, 1.5, 0.2]), advance_pose(np.array([1.0, 1.5, 0.2]), 0.7, 0.4)]  # an arc, as odometry sees it
    course_log = scans_only_log(path, ROOM, odometry=True)
    motion, present = wheel_motion(course_log, 0, 2)
    assert present
    assert motion == pytest.approx(relative(*path), abs=1e-9)
    result = laser_odometry(course_log, FRONT_LASER, ScanMatchParams())
    assert result.had_odometry.tolist() == [False, True]
    assert result.increments[1] == pytest.approx(relative(*path), abs=0.005)


def test_scans_without_returns_fall_back_on_the_odometry():
    course_log = scans_only_log([np.zeros(3), np.array([0.5, 0.0, 0.1])], CORRIDOR[:0], odometry=True)
    assert not course_log.scans.any()  # no walls: no returns
    result = laser_odometry(course_log, FRONT_LASER, ScanMatchParams())
    assert not result.accepted.any()
    assert result.increments[1] == pytest.approx(result.wheel_increments[1])


@pytest.mark.parametrize(
    "change, message",
    [
        ({"point_noise": 0.0}, "point_noise"),
        ({"min_range": 5.0, "max_range": 2.0}, "min_range"),
        ({"correspondence_distances": ()}, "correspondence_distances"),
        ({"min_overlap": 1.5}, "min_overlap"),
    ],
)
def test_impossible_settings_are_refused(change, message):
    with pytest.raises(ValueError, match=message):
        ScanMatchParams(**change)


def loop_in_the_room():
    """Poses every half metre round a loop in ROOM (east, north, west, south), turning 45 degrees
    a step at the corners."""
    poses, pose = [], np.array([1.5, 4.5, 0.0])
    for straight in (18, 5, 18, 5):
        for _ in range(straight):
            poses.append(pose)
            pose = compose(pose, [0.5, 0.0, 0.0])
        for _ in range(2):
            poses.append(pose)
            pose = compose(pose, [0.0, 0.0, math.pi / 4])
    return poses


@pytest.mark.slow
def test_mazeslam_slam_moves_by_laser_odometry_on_a_log_without_odometry(tmp_path):
    from click.testing import CliRunner

    from mazeslam.cli.main import main
    from mazeslam.data import log, sidecars

    poses = loop_in_the_room()
    course_log = scans_only_log(poses, ROOM)
    path = tmp_path / "room.log"
    log.write(path, course_log)
    sidecars.write_truth(sidecars.truth_path(path), course_log.times, np.array(poses))
    sensor = {"beams": BEAMS, "max_range": MAX_RANGE, **FRONT_LASER.to_dict()}
    sidecars.write_map(sidecars.map_path(path), ROOM, np.empty((0, 2)), sensor, start_pose=poses[0].tolist())
    config = tmp_path / "laser.toml"
    config.write_text(
        "[fastslam]\nsigmaX = 0.02\nsigmaTH = 0.01\nsigmaTH_drive = 0.005\nview_range = 3.0\n"
        "[scan_matching]\nenabled = true\n[scan_matching.correlative]\nturn_step = 2.0\n"
    )
    result = CliRunner().invoke(
        main,
        ["slam", str(path), "--config", str(config), "--out", str(tmp_path / "out"), "--quiet"],
        catch_exceptions=False,
    )
    assert result.exit_code == 0, result.output
    assert f"{len(poses) - 1} of {len(poses) - 1} scan-to-scan matches accepted" in result.output
    assert "at the scans (the filter estimates no pose of its own between scans)" in result.output
    table = dict(
        line.split("|")[1:3]
        for line in result.output.splitlines()
        if line.startswith("| FastSLAM") or line.startswith("| laser") or line.startswith("| dead")
    )
    ate = {name.strip(): float(value) for name, value in table.items()}
    assert ate["dead reckoning"] > 5.0  # no odometry: dead reckoning stands at the start
    # Along the north wall the laser sees little across the room's length; one such step slides ~14 cm.
    assert ate["laser odometry"] < 0.15
    assert ate["FastSLAM (mean)"] < 0.2


def test_laser_odometry_on_a_log_without_scans_is_refused(tmp_path):
    from mazeslam.data import log
    from mazeslam.pipeline import SlamConfig, slam_on_file

    path = tmp_path / "odometry_only.log"
    log.write(path, CourseLog(np.array([0.0, 1.0]), np.array([ODOMETRY, ODOMETRY]), np.array([[0.1, 0.0], [0.1, 0.1]])))
    config = SlamConfig(scan_matching=ScanMatchParams(enabled=True))
    with pytest.raises(ValueError, match=r"\[scan_matching\] needs a log of scans"):
        slam_on_file(path, config, progress=False)
