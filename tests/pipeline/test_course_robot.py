"""The course robot end to end: its simulated logs mapped by configs/course.toml's grid filter."""

import dataclasses

from conftest import PROJECT_ROOT

from mazeslam import simulate
from mazeslam.data.loaded_run import load_run
from mazeslam.evaluation.metrics import absolute_trajectory_error
from mazeslam.evaluation.sharpness import dead_reckoning_without_glitches, map_sharpness
from mazeslam.pipeline import MapKind, load_slam_config, run_slam
from mazeslam.sim.simulator import load_config


def test_the_course_config_beats_dead_reckoning_on_a_simulated_course_robot_log(tmp_path):
    simulation = load_config(PROJECT_ROOT / "configs" / "simulation_course_robot.toml")
    run = simulate(tmp_path / "course.log", config=simulation, seed=7, duration=60, progress=False)
    loaded = load_run(run.log_path)
    config = load_slam_config(PROJECT_ROOT / "configs" / "course.toml")
    config = dataclasses.replace(config, grid=dataclasses.replace(config.grid, particles=10))
    result = run_slam(loaded, config, progress=False)  # [map] kind = grid: the grid filter
    assert result.kind == MapKind.GRID and result.grid is not None
    mean = result.mean_poses
    reckoned = dead_reckoning_without_glitches(loaded, config.odometry.jump_tolerance)
    assert loaded.truth is not None
    filter_error = absolute_trajectory_error(mean, loaded.truth)["rmse"]
    reckoning_error = absolute_trajectory_error(reckoned, loaded.truth)["rmse"]
    assert filter_error < 0.5 * reckoning_error, (filter_error, reckoning_error)
    assert map_sharpness(loaded, mean, config.odometry.jump_tolerance).ratio < 0.9
