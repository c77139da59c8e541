"""Calibration recovers the simulator's known noise from the logs alone."""

import dataclasses

import numpy as np
import pytest

from mazeslam.calibration.noise import laser_range_noise
from mazeslam.data.loaded_run import load_run
from mazeslam.features.corners import CornerExtractor
from mazeslam.sim.simulator import SimulationConfig


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

    from mazeslam.calibration.noise import calibrate
    from mazeslam.pipeline import SlamConfig

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

    from mazeslam.cli.main import main
    from mazeslam.pipeline import load_slam_config

    written = tmp_path / "calibrated.toml"
    result = CliRunner().invoke(main, ["calibrate", str(default_run.log_path), "--write", str(written), "--quiet"])
    assert result.exit_code == 0, result.output
    assert "against truth" in result.output
    config = load_slam_config(written)  # the printed settings are a valid config
    assert config.corners.covariance_scale["wall_end"] > config.corners.covariance_scale["corner"]


def test_the_range_noise_of_several_logs_pools_their_lines_by_degrees_of_freedom():
    """Hand-computed: 100 points on 10 lines (80 dof) at 2 mm and 50 on 5 (40 dof) at 5 mm pool to
    sqrt((80 x 4 + 40 x 25) / 120) mm."""
    import math

    from mazeslam.calibration.noise import RangeNoise, pooled_range_noise

    pooled = pooled_range_noise([RangeNoise(0.002, 100, 10), RangeNoise(0.005, 50, 5)])
    assert pooled.std == pytest.approx(math.sqrt((80 * 0.002**2 + 40 * 0.005**2) / 120))
    assert (pooled.points, pooled.lines) == (150, 15)


def test_a_log_calibrated_twice_over_gives_its_own_settings_on_twice_the_data(default_run):
    """Pooling is a round trip: the same log given twice fits the same noise from twice the
    stretches and observations, and its repeat correlations do not pair one copy with the other."""
    from mazeslam.calibration.noise import calibrate, calibrate_logs
    from mazeslam.pipeline import SlamConfig

    run = load_run(default_run.log_path)
    alone, twice = calibrate(run, SlamConfig()), calibrate_logs([run, run], SlamConfig())
    assert twice.source.startswith("2 logs")
    assert twice.motion.stretches == 2 * alone.motion.stretches
    assert twice.observations.observations == 2 * alone.observations.observations
    assert twice.motion.noise.sigmaX == pytest.approx(alone.motion.noise.sigmaX)
    assert twice.range_noise.std == pytest.approx(alone.range_noise.std)
    for kind in alone.observations.kind_scales:
        assert twice.observations.widths[kind] == pytest.approx(alone.observations.widths[kind])
        assert twice.observations.correlations[kind] == pytest.approx(alone.observations.correlations[kind])


def test_the_calibrate_command_takes_several_logs_of_one_family(default_run):
    from click.testing import CliRunner

    from mazeslam.cli.main import main

    log = str(default_run.log_path)
    result = CliRunner().invoke(main, ["calibrate", log, log, "--quiet"])
    assert result.exit_code == 0, result.output
    assert f"measured by mazeslam calibrate on 2 logs ({log}, {log}) against truth" in result.output


def test_pooled_residuals_number_each_logs_landmarks_and_updates_apart():
    """Hand-made: two logs that both see their landmark 0 in updates 0 and 1. Pooled, log B's
    landmark is another landmark and its updates do not follow log A's, so no repeat pair crosses
    from one log to the other."""
    from mazeslam.calibration.noise import Residuals, pooled_residuals

    def residuals(error: float) -> Residuals:
        return Residuals(
            np.full((2, 2), error),
            np.tile(np.eye(2), (2, 1, 1)),
            np.array(["corner"] * 2),
            np.zeros(2, int),
            np.arange(2),
        )

    pooled = pooled_residuals([residuals(0.1), residuals(0.2)])
    assert pooled.landmarks.tolist() == [0, 0, 1, 1]
    assert pooled.updates.tolist() == [0, 1, 3, 4]
    assert pooled.errors[:, 0].tolist() == [0.1, 0.1, 0.2, 0.2]
    assert pooled.kinds.tolist() == ["corner"] * 4


def test_a_landmark_record_inside_a_scan_log_is_refused_at_its_line(default_run, tmp_path):
    """Issue 36 item 11: calibrating such a log ended in 'array must not contain infs or NaNs' (the
    filter's NaN trajectory); the log is now refused where it is read, naming the line."""
    import shutil

    from mazeslam.data import sidecars
    from mazeslam.data.log import LogFormatError

    lines = default_run.log_path.read_text().splitlines()
    width = len(lines[0].split())
    lines.insert(6, f"{lines[5].split()[0]} 2 3 0.2 0.1 " + " ".join(["-1"] * (width - 5)))
    path = tmp_path / "mixed.log"
    path.write_text("\n".join(lines) + "\n")
    shutil.copy(sidecars.map_path(default_run.log_path), sidecars.map_path(path))
    with pytest.raises(LogFormatError, match=r"mixed.log:7: a landmark observation \(flag 2\) in a log of \d+ scans"):
        load_run(path)


def test_without_truth_the_reference_is_corner_fastslam_whatever_the_map_kind(default_run):
    """calibrate measures corner noises against corner FastSLAM's landmarks: a config whose [map] kind
    is grid (configs/course.toml, configs/carmen.toml) gives the same settings as the landmark one."""
    from mazeslam.calibration.noise import calibrate
    from mazeslam.core.config import with_settings
    from mazeslam.pipeline import SlamConfig

    run = dataclasses.replace(load_run(default_run.log_path), truth=None)
    landmarks = SlamConfig(fastslam=dataclasses.replace(SlamConfig().fastslam, NPARTICLES=20))
    grid = with_settings(landmarks, {"map.kind": "grid"})
    assert calibrate(run, grid).settings() == calibrate(run, landmarks).settings()
