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
