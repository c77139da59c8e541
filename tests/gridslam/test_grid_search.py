"""The grid filter's wide search at every scan (``GridSlamParams.search``): on a log without odometry
the scan matcher alone moves the robot, and its motion can be a right angle wrong while the scan
still lies on walls."""

import numpy as np
import pytest

from mazeslam.core.geometry import wrap_angle
from mazeslam.data import log
from mazeslam.gridslam import GridSlam, GridSlamParams, run_grid_slam
from mazeslam.gridslam.filter import ScanSensor, SearchMode
from mazeslam.sim.building import LASER, building_walls
from mazeslam.sim.laser import VirtualLaser

BEARINGS = LASER.geometry.bearings(LASER.beams)
#: The robot drives along the ring's lower corridor (2 m wide, its centre line at y = 1), facing +x.
PATH = np.array([[x, 1.0, 0.0] for x in (1.0, 1.5, 2.0, 2.5, 3.0, 3.5)])
#: The motion the filter is told for the last step: the 0.5 m forward, and a turn of 1.5 rad that
#: never happened (as orebro's laser odometry between its scans 212 and 213): twice the failed-match
#: rescue's +-0.75 rad window, within every scan's +-1.75 rad.
WRONG_MOTION = np.array([0.5, 0.0, 1.5])


def poses_after_a_wrong_turn(search: str) -> np.ndarray:
    """Every particle's pose (P, 3) after the scans of ``PATH``, mapped with the true motions but
    the last, which is ``WRONG_MOTION``."""
    laser, rng = VirtualLaser(LASER, building_walls()), np.random.default_rng(3)
    params = GridSlamParams(particles=4, search=search)
    sensor = ScanSensor(BEARINGS, np.zeros(2))
    slam = GridSlam(params, PATH[0], sensor)
    motions = [np.zeros(3)] + [np.array([0.5, 0.0, 0.0])] * (len(PATH) - 2) + [WRONG_MOTION]
    for pose, motion in zip(PATH, motions):
        slam.process(laser.scan(pose, rng), motion)
    return slam.poses


def test_searching_at_every_scan_undoes_a_wrong_turn_of_the_motion():
    poses = poses_after_a_wrong_turn("every-scan")
    # Along the corridor only its pillars place a scan: a particle may end up to a decimetre ahead.
    assert np.all(np.hypot(*(poses[:, :2] - PATH[-1, :2]).T) < 0.15)
    assert np.all(np.abs(wrap_angle(poses[:, 2] - PATH[-1, 2])) < 0.02)


def test_searching_only_on_a_failed_match_keeps_that_turn():
    poses = poses_after_a_wrong_turn("failed-match")
    assert np.all(np.abs(wrap_angle(poses[:, 2] - PATH[-1, 2])) > 0.5)


@pytest.mark.parametrize(("search", "every_scan"), [("every-scan", True), ("failed-match", False)])
def test_the_search_setting_is_an_enum_that_says_when_the_search_runs(search, every_scan):
    params = GridSlamParams(search=search)
    assert params.search == SearchMode(search) and isinstance(params.search, SearchMode)
    slam = GridSlam(params, PATH[0], ScanSensor(BEARINGS, np.zeros(2)))
    assert slam.search_every_scan is every_scan


def _log(with_odometry: bool) -> log.CourseLog:
    """Scans along ``PATH`` from the simulated building's laser, with an odometry record between
    every two (the true motion) or without any."""
    laser, rng = VirtualLaser(LASER, building_walls()), np.random.default_rng(4)
    lines = []
    for index, pose in enumerate(PATH):
        if with_odometry and index:
            lines.append(f"{index - 0.5:.1f} 0 0.5 0.0 " + " ".join(["-1"] * (LASER.beams - 2)))
        lines.append(f"{index:.1f} 1 " + " ".join(f"{r:.4f}" for r in laser.scan(pose, rng)))
    return log.parse("\n".join(lines) + "\n")


@pytest.mark.parametrize(("search", "searches"), [("every-scan", len(PATH)), ("failed-match", 0)])
def test_run_grid_slam_searches_every_scan_when_told_to(monkeypatch, search, searches):
    calls = []
    original = GridSlam._searched_offsets

    def counted(self, *args):
        calls.append(1)
        return original(self, *args)

    monkeypatch.setattr(GridSlam, "_searched_offsets", counted)
    params = GridSlamParams(particles=2, linear_update=0.0, motion="wheels", search=search)
    run_grid_slam(_log(with_odometry=False), LASER.geometry, PATH[0], params)
    assert len(calls) == searches


def test_bad_search_settings_are_named():
    with pytest.raises(
        ValueError, match="GridSlamParams: search = 'always': must be one of 'failed-match', 'every-scan'"
    ):
        GridSlamParams(search="always")
    with pytest.raises(ValueError, match=r"every_scan_sigma: 2 positive values \(m, rad\)"):
        GridSlamParams(every_scan_sigma=(0.4, 0.0))
