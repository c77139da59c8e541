"""Measuring a log's odometry noise against its truth, checked against the simulator's slip model."""

import dataclasses
import math

import numpy as np
import pytest
from click.testing import CliRunner

from mazeslam import simulate
from mazeslam.calibration.odometry_noise import measure_odometry_noise
from mazeslam.cli.main import main
from mazeslam.data import log, sidecars
from mazeslam.sim.odometry import OdometryParams
from mazeslam.sim.simulator import SimulationConfig
from mazeslam.sim.world import RobotParams


def run_with_slip(tmp_path, slip_std):
    config = SimulationConfig()
    config = dataclasses.replace(
        config, odometry=OdometryParams(slip_std=slip_std), maze=dataclasses.replace(config.maze, rows=8, cols=8)
    )
    return simulate(tmp_path / "run.log", config, seed=3, progress=False)


def measured(run):
    return measure_odometry_noise(log.read(run.log_path), sidecars.read_truth(run.truth_path)[1])


def test_measured_noise_matches_the_wheel_slip_it_comes_from(tmp_path):
    """Each wheel slips by slip_std sqrt(travel), independently. Driving a distance d, both wheels
    travel d: the distance (l + r) / 2 errs by slip_std sqrt(d / 2), the heading (r - l) / b by
    slip_std sqrt(2 d) / b. Turning dtheta on the spot, each wheel travels b dtheta / 2: the heading
    errs by slip_std sqrt(dtheta / b)."""
    slip, wheelbase = 0.003, RobotParams().wheelbase
    noise = measured(run_with_slip(tmp_path, slip))
    assert noise.stretches > 500 and noise.distance > 10
    assert noise.noise.sigmaX == pytest.approx(slip / math.sqrt(2), rel=0.15)
    assert noise.noise.sigmaTH_drive == pytest.approx(slip * math.sqrt(2) / wheelbase, rel=0.15)
    assert noise.noise.sigmaTH == pytest.approx(slip / math.sqrt(wheelbase), rel=0.15)


def test_without_slip_only_a_small_floor_remains(tmp_path):
    """Whole encoder steps, the 1e-6 rounding of the log and brushing walls leave a floor at least
    five times below the default slip's noise (0.0021, 0.013, 0.080)."""
    noise = measured(run_with_slip(tmp_path, 0.0))
    assert noise.noise.sigmaX < 0.0021 / 5 and noise.noise.sigmaTH < 0.013 / 5 and noise.noise.sigmaTH_drive < 0.080 / 5


def test_bad_input_is_named(default_run):
    course_log = log.read(default_run.log_path)
    with pytest.raises(ValueError, match="one pose"):
        measure_odometry_noise(course_log, np.zeros((3, 3)))
    odometry_only = log.CourseLog(
        course_log.times[~course_log.is_scan],
        course_log.flags[~course_log.is_scan],
        course_log.values[~course_log.is_scan],
    )
    with pytest.raises(ValueError, match="at least two observations"):
        measure_odometry_noise(odometry_only, np.zeros((len(odometry_only), 3)))


def test_command_prints_fastslam_settings_or_names_the_missing_truth(default_run, tmp_path):
    result = CliRunner().invoke(main, ["odometry-noise", str(default_run.log_path)])
    assert result.exit_code == 0, result.output
    assert "[fastslam]" in result.output and "sigmaTH_drive = " in result.output
    bare = tmp_path / "bare.log"
    bare.write_text(default_run.log_path.read_text())
    result = CliRunner().invoke(main, ["odometry-noise", str(bare)])
    assert result.exit_code != 0 and "no truth sidecar" in result.output


def test_command_trimmed_prints_the_trimmed_fit_and_what_it_left_out(default_run):
    from mazeslam.calibration.odometry_noise import fit_noise_trimmed, stretch_errors

    errors = stretch_errors(log.read(default_run.log_path), sidecars.read_truth(default_run.truth_path)[1])
    expected = fit_noise_trimmed(errors)  # wheel odometry: no floor
    result = CliRunner().invoke(main, ["odometry-noise", str(default_run.log_path), "--trimmed"])
    assert result.exit_code == 0, result.output
    assert f"# trimmed: {expected.left_out} stretches left out" in result.output
    assert f"sigmaX = {expected.noise.sigmaX:.4g} " in result.output
    assert f"sigmaTH_drive = {expected.noise.sigmaTH_drive:.4g} " in result.output


def test_laser_odometry_errors_by_hand():
    from mazeslam.calibration.odometry_noise import laser_stretch_errors
    from mazeslam.registration.scan_matching import LaserOdometry

    truth = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, np.pi / 2]])  # 1 m east, then 1 m north facing north
    increments = np.array([[0.0, 0.0, 0.0], [0.9, 0.0, 0.01], [0.0, 1.0, np.pi / 2]])  # the first step 10 cm short
    laser = LaserOdometry(np.arange(3), increments, np.zeros((3, 3)), np.ones(3, bool), np.ones(3, bool), np.ones(3))
    rows = laser_stretch_errors(laser, truth)
    # second interval in the robot frame at (1, 0, 0): the true step is (0, 1, pi/2), laser's exact
    assert rows == pytest.approx(np.array([[0.9, 0.01, 0.1, -0.01], [1.0, np.pi / 2, 0.0, 0.0]]), abs=1e-12)
    with pytest.raises(ValueError, match="one pose per scan"):
        laser_stretch_errors(laser, truth[:2])


def model_errors(rng, count, sigma_x, sigma_th, sigma_drive):
    """Stretch errors (count, 4) drawn from the filter's motion model with known sigmas."""
    moved, turned = rng.uniform(0.2, 2.0, count), rng.uniform(0.0, 1.0, count)
    along = rng.normal(0.0, sigma_x * np.sqrt(moved))
    heading = rng.normal(0.0, np.sqrt(sigma_th**2 * turned + sigma_drive**2 * moved))
    return np.column_stack([moved, turned, along, heading])


def test_trimmed_fit_ignores_failed_matches_that_pull_the_plain_fit_up():
    from mazeslam.calibration.odometry_noise import fit_noise, fit_noise_trimmed

    rng = np.random.default_rng(5)
    errors = model_errors(rng, 2000, 0.02, 0.01, 0.004)
    failed = rng.choice(len(errors), 60, replace=False)  # 3 % of the matches a metre or half a radian off
    errors[failed, 2] += rng.choice([-1.0, 1.0], len(failed)) * rng.uniform(0.5, 2.0, len(failed))
    errors[failed, 3] += rng.choice([-1.0, 1.0], len(failed)) * rng.uniform(0.3, 1.5, len(failed))
    plain, trimmed = fit_noise(errors).noise, fit_noise_trimmed(errors)
    assert plain.sigmaX > 5 * 0.02 and plain.sigmaTH_drive > 5 * 0.004
    assert trimmed.noise.sigmaX == pytest.approx(0.02, rel=0.1)
    assert trimmed.noise.sigmaTH == pytest.approx(0.01, rel=0.15)
    assert trimmed.noise.sigmaTH_drive == pytest.approx(0.004, rel=0.15)
    assert 60 <= trimmed.left_out <= 90 and trimmed.stretches == 2000 - trimmed.left_out


def test_trimmed_fit_of_clean_errors_is_the_plain_fit_within_its_spread():
    from mazeslam.calibration.odometry_noise import fit_noise, fit_noise_trimmed

    errors = model_errors(np.random.default_rng(6), 2000, 0.03, 0.02, 0.01)
    plain, trimmed = fit_noise(errors), fit_noise_trimmed(errors)
    assert trimmed.left_out <= 0.01 * len(errors)
    for name in ("sigmaX", "sigmaTH", "sigmaTH_drive"):
        assert getattr(trimmed.noise, name) == pytest.approx(getattr(plain.noise, name), rel=0.05)


def test_trimmed_fit_keeps_still_stretches_whose_error_is_within_the_floor():
    from mazeslam.calibration.odometry_noise import fit_noise_trimmed

    rng = np.random.default_rng(7)
    errors = model_errors(rng, 1000, 0.02, 0.01, 0.004)
    still = rng.choice(len(errors), 200, replace=False)  # the robot barely moved: 1 mm, no turn
    errors[still] = np.column_stack(
        [np.full(200, 0.001), np.zeros(200), rng.normal(0, 0.003, 200), rng.normal(0, 0.003, 200)]
    )
    assert fit_noise_trimmed(errors).left_out > 150  # without a floor they are far beyond sqrt(a D)
    assert fit_noise_trimmed(errors, floor=0.01).left_out < 20  # 3 mm errors are within 3 x 1 cm


def test_trimmed_fit_of_nothing_but_outliers_says_so():
    from mazeslam.calibration.odometry_noise import fit_noise_trimmed

    errors = np.array([[1.0, 0.0, (-1.0) ** k * 0.01, 0.0] for k in range(20)] + [[1.0, 0.0, 5.0, 0.0]])
    trimmed = fit_noise_trimmed(errors)  # the first fit's sigmaX is 1.09, and 5 m lies beyond 3 of it
    assert trimmed.left_out == 1 and trimmed.noise.sigmaX == pytest.approx(0.01)
    with pytest.raises(ValueError, match="did not settle|nothing is left"):
        fit_noise_trimmed(errors, sigmas=0.001)
