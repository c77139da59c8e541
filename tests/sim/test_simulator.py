import dataclasses

import numpy as np
import pytest
from conftest import PROJECT_ROOT, assert_scans_match_truth_and_map

from mazeslam import simulate
from mazeslam.core.beams import BeamGeometry
from mazeslam.core.config import ConfigError
from mazeslam.core.motion import dead_reckoning
from mazeslam.data import log, sidecars
from mazeslam.sim.laser import LaserParams
from mazeslam.sim.maze import generate_maze, load_maze
from mazeslam.sim.odometry import OdometryParams
from mazeslam.sim.policies import ScriptedPolicy, load_commands
from mazeslam.sim.simulator import LoggerParams, MazeParams, SimulationConfig, load_config

CONFIGS = PROJECT_ROOT / "configs"


def test_default_run_scans_agree_with_truth_and_map(default_run):
    course_log, truth, _ = assert_scans_match_truth_and_map(default_run.log_path)
    assert course_log.n_beams == 180
    assert default_run.policy_finished


def test_16x16_maze_scans_agree_with_truth_and_map(tmp_path):
    config = dataclasses.replace(SimulationConfig(), maze=MazeParams(rows=16, cols=16))
    result = simulate(tmp_path / "big.log", config=config, seed=2, duration=120, progress=False)
    assert result.maze.rows == 16
    assert_scans_match_truth_and_map(result.log_path)


def test_other_beam_conventions_and_mounting_are_recorded_and_cast(tmp_path):
    laser = LaserParams(beams=90, geometry=BeamGeometry(first_beam_angle=np.pi / 2, direction=-1, mount_x=0.02))
    config = dataclasses.replace(SimulationConfig(), laser=laser)
    result = simulate(tmp_path / "conv.log", config=config, seed=1, duration=30, progress=False)
    _, _, world = assert_scans_match_truth_and_map(result.log_path)
    assert world["sensor"]["direction"] == -1 and world["sensor"]["mount_x"] == 0.02
    assert list(world["sensor"]) == [
        "beams",
        "max_range",
        "min_range",
        "model",
        "range_noise_std",
        "dropout",
        "first_beam_angle",
        "direction",
        "field_of_view",
        "mount_x",
        "mount_y",
    ]


def test_same_seed_same_bytes_other_seed_other_run(tmp_path):
    def run(name, seed):
        result = simulate(tmp_path / f"{name}.log", seed=seed, duration=20, progress=False)
        return [p.read_bytes() for p in (result.log_path, result.truth_path, result.map_path)]

    first, again, other = run("a", 5), run("b", 5), run("c", 6)
    assert first == again
    assert first[0] != other[0]


def test_noise_free_odometry_dead_reckons_the_truth(tmp_path):
    config = dataclasses.replace(SimulationConfig(), odometry=OdometryParams(slip_std=0.0))
    result = simulate(tmp_path / "exact.log", config=config, seed=3, progress=False)
    course_log = log.read(result.log_path)
    world = sidecars.read_map(result.map_path)
    estimate = dead_reckoning(course_log, world["start_pose"])
    # Only encoder quantisation (0.13 mm a step) separates them.
    assert np.abs(estimate[:, :2] - result.poses[:, :2]).max() < 3e-3


def test_odometry_glitches_change_only_the_listed_records_and_leave_the_truth(tmp_path):
    glitchy = dataclasses.replace(SimulationConfig(), odometry=OdometryParams(glitch_rate=0.05))
    clean = simulate(tmp_path / "clean.log", seed=4, duration=60, progress=False)
    result = simulate(tmp_path / "glitchy.log", config=glitchy, seed=4, duration=60, progress=False)
    assert result.truth_path.read_bytes() == clean.truth_path.read_bytes()
    clean_log, course_log = log.read(clean.log_path), log.read(result.log_path)
    np.testing.assert_array_equal(course_log.scans, clean_log.scans)
    glitches = sidecars.read_map(result.map_path)["odometry_glitches"]
    changed = np.flatnonzero(np.any(course_log.values[:, :2] != clean_log.values[:, :2], axis=1))
    assert len(glitches) > 3 and changed.tolist() == [index for index, _ in glitches]
    difference = course_log.values[:, :2] - clean_log.values[:, :2]  # (dX, dTheta) each glitch added
    for (index, kind), following in zip(glitches, [*glitches[1:], None]):
        if kind == "pair_first":  # taken back at the next odometry record (a scan may lie between)
            assert following[1] == "pair_second"
            np.testing.assert_allclose(difference[index] + difference[following[0]], 0.0, atol=2e-6)
        elif kind == "lone":
            np.testing.assert_allclose(difference[index], [-2 * glitchy.odometry.glitch_distance, 0.0], atol=2e-6)


def test_a_logger_that_scans_between_odometry_records(tmp_path):
    logger = LoggerParams(scan_period=0.75, odometry_rate=4.0, odometry_with_scan=False, scan_phase=-0.06)
    config = dataclasses.replace(SimulationConfig(), logger=logger)
    course_log = log.read(simulate(tmp_path / "lag.log", config=config, seed=2, duration=20, progress=False).log_path)
    scan_times, odometry_times = course_log.times[course_log.is_scan], course_log.times[course_log.is_odometry]
    np.testing.assert_allclose(scan_times, 0.75 * np.arange(1, len(scan_times) + 1) - 0.06, atol=0.011)
    assert not set(np.round(scan_times, 6)) & set(np.round(odometry_times, 6))
    assert len(odometry_times) == pytest.approx(4 * 20, abs=1)
    before = [scan - odometry_times[odometry_times < scan].max() for scan in scan_times]
    np.testing.assert_allclose(before, 0.19, atol=0.011)  # 4 Hz: the record 0.25 - 0.06 s before


def test_explorer_visits_every_cell_and_returns(default_run):
    maze = default_run.maze
    visited = {maze.cell_of(x, y) for x, y, _ in default_run.poses}
    assert visited == {(r, c) for r in range(maze.rows) for c in range(maze.cols)}
    start = maze.cell_center(*maze.start_cell)
    assert np.hypot(*(default_run.poses[-1, :2] - start)) < 0.03


def test_record_rates_follow_the_logger_settings(default_run):
    course_log = log.read(default_run.log_path)
    scan_times = course_log.times[course_log.is_scan]
    assert np.median(np.diff(scan_times)) == pytest.approx(0.75, abs=0.02)
    odometry_times = course_log.times[course_log.is_odometry]
    assert np.median(np.diff(odometry_times)) == pytest.approx(0.2, abs=1e-6)
    # Every scan follows an odometry record with the same timestamp.
    scan_rows = np.flatnonzero(course_log.is_scan)
    assert np.all(course_log.flags[scan_rows - 1] == log.ODOMETRY)
    np.testing.assert_array_equal(course_log.times[scan_rows - 1], course_log.times[scan_rows])


def test_scripted_policy_drives_open_loop(tmp_path):
    config = dataclasses.replace(SimulationConfig(), odometry=OdometryParams(slip_std=0.0))
    policy = ScriptedPolicy([(2.0, 0.05, 0.0), (1.0, 0.0, 0.5)])
    result = simulate(
        tmp_path / "s.log",
        config=config,
        maze=CONFIGS / "mazes" / "paper_sheet.txt",
        policy=policy,
        duration=4.0,
        progress=False,
    )
    start = result.maze.cell_center(0, 0)
    final = result.poses[-1]
    np.testing.assert_allclose(final[:2], start + [0.1, 0.0], atol=1e-3)
    assert final[2] == pytest.approx(0.5, abs=0.01)


def test_load_commands(tmp_path):
    path = tmp_path / "cmd.txt"
    path.write_text("# duration speed turn\n1.0 0.05 0\n2, 0, 0.3\n")
    policy = load_commands(path)
    assert policy(0.5, None) == (0.05, 0.0) and policy(2.0, None) == (0.0, 0.3)
    assert policy(3.5, None) == (0.0, 0.0) and policy.done
    path.write_text("1.0 0.05\n")
    with pytest.raises(ValueError, match=r"cmd.txt:1: expected 'duration speed turn_rate'"):
        load_commands(path)


def test_maze_file_run(tmp_path):
    result = simulate(tmp_path / "p.log", maze=CONFIGS / "mazes" / "large_8x8.txt", seed=0, duration=60, progress=False)
    assert result.maze.rows == 8
    assert_scans_match_truth_and_map(result.log_path)


def test_shipped_config_equals_the_defaults():
    assert load_config(CONFIGS / "simulation.toml") == SimulationConfig()


def test_toml_overrides_only_what_it_names(tmp_path):
    path = tmp_path / "c.toml"
    path.write_text("[laser]\nbeams = 90\n[maze]\nrows = 2\n")
    config = load_config(path)
    assert config.laser.beams == 90 and config.maze.rows == 2
    assert config.laser.max_range == LaserParams().max_range


def test_toml_sets_the_beam_geometry_in_its_own_table(tmp_path):
    path = tmp_path / "c.toml"
    path.write_text("[laser]\nbeams = 90\n[laser.geometry]\nfirst_beam_angle = 0.0\nmount_x = 0.03\n")
    assert load_config(path).laser == LaserParams(beams=90, geometry=BeamGeometry(first_beam_angle=0.0, mount_x=0.03))


@pytest.mark.parametrize(
    "text, message",
    [
        ("[laser]\nbeam = 90\n", r"c.toml \[laser\]: unknown parameter\(s\) beam"),
        ("[laser]\nbeams = 0\n", r"c.toml \[laser\]: laser beams must be at least 1"),
        ("[laser]\nmount_x = 0.1\n", r"c.toml \[laser\]: unknown parameter\(s\) mount_x; known: .*geometry"),
        ("[laser.geometry]\ndirection = 2\n", r"c.toml \[laser\] \[geometry\]: beam direction must be \+1 or -1"),
        ("[logger]\nscan_period = -1\n", "scan_period must be positive"),
        ("[drive]\ncruise_speed = 0.5\n", "exceeds the robot's max_wheel_speed"),
        ("[laser\n", "not valid TOML"),
    ],
)
def test_bad_configs_name_file_section_and_reason(tmp_path, text, message):
    path = tmp_path / "c.toml"
    path.write_text(text)
    with pytest.raises(ConfigError, match=message):
        load_config(path)


def test_impossible_run_parameters(tmp_path):
    with pytest.raises(ValueError, match="duration"):
        simulate(tmp_path / "x.log", duration=-1, progress=False)
    with pytest.raises(ValueError, match="at least one row"):
        generate_maze(0, 3)
    with pytest.raises(ValueError, match="not found"):
        load_maze(tmp_path / "none.txt")
