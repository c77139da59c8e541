"""``mazeslam odometry-noise``: a log's odometry noise (wheel or laser odometry) measured against its
truth sidecar, as ``[fastslam]`` settings."""

from __future__ import annotations

from pathlib import Path

import click


@click.command(name="odometry-noise")
@click.argument("log_file", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option(
    "--config",
    "config_path",
    type=click.Path(exists=True, dir_okay=False, path_type=Path),
    help="A slam config; with [scan_matching] enabled, the laser odometry is measured instead.",
)
@click.option(
    "--trimmed",
    is_flag=True,
    help="Fit again without the stretches beyond 3 standard deviations of the fit (failed scan matches, "
    "glitches; for laser odometry at least [scan_matching] prior_floor), until none is left out anew; "
    "prints how many were.",
)
def odometry_noise(log_file, config_path, trimmed):
    """Measure a log's odometry noise against its truth sidecar, as [fastslam] settings."""
    from mazeslam.calibration.odometry_noise import (
        OUTLIER_SIGMAS,
        fit_noise,
        fit_noise_trimmed,
        motion_stretch_errors,
    )
    from mazeslam.data.loaded_run import load_run
    from mazeslam.pipeline import load_slam_config
    from mazeslam.registration.scan_matching import laser_odometry

    config = load_slam_config(config_path)
    run = load_run(log_file, config.sensor)
    if run.truth is None:
        raise click.ClickException(
            f"{log_file}: no truth sidecar {run.name}.truth.csv: the noise is measured against it"
        )
    truth_file = f"{run.name}.truth.csv"
    laser = laser_odometry(run.log, run.geometry, config.scan_matching) if config.scan_matching.enabled else None
    source = "laser odometry" if laser is not None else "odometry"
    try:
        errors = motion_stretch_errors(run.log, run.truth, laser)
        floor = config.scan_matching.prior_floor if laser is not None else 0.0
        noise = fit_noise_trimmed(errors, floor) if trimmed else fit_noise(errors)
    except ValueError as error:
        raise click.ClickException(f"{log_file}: {error}") from error
    click.echo(
        f"# {log_file}: {noise.stretches} stretches between observations, {noise.distance:.2f} m driven, "
        f"{noise.turn:.1f} rad turned ({source} against {truth_file})"
    )
    if trimmed:
        click.echo(
            f"# trimmed: {noise.left_out} stretches left out, beyond {OUTLIER_SIGMAS:g} standard deviations of the fit "
            f"(at least {floor:g} m and rad)"
        )
    click.echo("[fastslam]")
    click.echo(f"sigmaX = {noise.noise.sigmaX:.4g}          # m per sqrt(m)")
    click.echo(f"sigmaTH = {noise.noise.sigmaTH:.4g}         # rad per sqrt(rad) turned")
    click.echo(f"sigmaTH_drive = {noise.noise.sigmaTH_drive:.4g}   # rad per sqrt(m) driven")
