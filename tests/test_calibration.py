"""Calibration recovers the simulator's known noise from the logs alone."""

import dataclasses

import pytest

from mazeslam.envs.simulator import SimulationConfig
from mazeslam.evaluation.calibration import laser_range_noise
from mazeslam.filters.corners import CornerExtractor
from mazeslam.loaded_run import load_run


def _range_noise(path):
    run = load_run(path)
    return laser_range_noise(run.log.values[run.log.is_scan], CornerExtractor(run.geometry, run.log.width))


def test_the_laser_range_noise_comes_back_from_the_walls_scatter(default_run):
    measured = _range_noise(default_run.log_path)
    assert measured.std == pytest.approx(SimulationConfig().laser.range_noise_std, rel=0.2)
    assert measured.lines > 100


def test_a_noisier_laser_is_measured_noisier(tmp_path):
    from mazeslam import simulate

    config = SimulationConfig()
    config = dataclasses.replace(config, laser=dataclasses.replace(config.laser, range_noise_std=0.006))
    run = simulate(tmp_path / "noisy.log", config=config, seed=3, duration=30.0, progress=False)
    assert _range_noise(run.log_path).std == pytest.approx(0.006, rel=0.2)


def test_calibrate_recovers_the_slip_and_finds_the_wall_ends_repeating_errors(default_run):
    import math

    from mazeslam.evaluation.calibration import calibrate
    from mazeslam.slam import SlamConfig

    measured = calibrate(load_run(default_run.log_path), SlamConfig())
    assert measured.reference == "truth"
    slip = SimulationConfig().odometry.slip_std  # per wheel: the distance's noise is slip / sqrt(2)
    assert measured.motion.noise.sigmaX == pytest.approx(slip / math.sqrt(2), rel=0.2)
    assert measured.range_noise.std == pytest.approx(SimulationConfig().laser.range_noise_std, rel=0.2)
    seen = measured.observations
    assert seen.correlations["corner"] < 0.2 < 0.5 < seen.correlations["wall_end"]
    assert seen.kind_scales["wall_end"] > 3 * seen.widths["wall_end"]


def test_the_calibrate_command_prints_settings_that_load(default_run, tmp_path):
    from click.testing import CliRunner

    from mazeslam.cli import main
    from mazeslam.slam import load_slam_config

    written = tmp_path / "calibrated.toml"
    result = CliRunner().invoke(main, ["calibrate", str(default_run.log_path), "--write", str(written), "--quiet"])
    assert result.exit_code == 0, result.output
    assert "against truth" in result.output
    config = load_slam_config(written)  # the printed settings are a valid config
    assert config.corners.covariance_scale["wall_end"] > config.corners.covariance_scale["corner"]
