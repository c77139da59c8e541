"""``run_slam``: the one entry to SLAM on a log, whichever filter ``[map] kind`` names."""

from __future__ import annotations

import sys
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from mazeslam.data.beam_detection import loaded_with_convention
from mazeslam.data.loaded_run import LoadedRun
from mazeslam.fastslam.filter import settings_hint
from mazeslam.pipeline.config import MapKind, SlamConfig, load_slam_config
from mazeslam.pipeline.fastslam_run import fastslam_on_run
from mazeslam.pipeline.grid_run import grid_on_run
from mazeslam.pipeline.log_kinds import CONFIGS_FOLDER, SETTINGS, chosen_config, log_kind
from mazeslam.pipeline.result import SlamResult
from mazeslam.registration.scan_matching import LaserOdometry


def run_slam(
    run: LoadedRun,
    config: SlamConfig | str | Path | None = None,
    progress: bool = True,
    snapshot_every: int = 0,
    laser: LaserOdometry | None = None,
    on_update=None,
) -> SlamResult:
    """The filter ``config.map.kind`` names over the loaded log ``run``: corner FastSLAM
    (``[fastslam]``, ``fastslam_on_run``) or the grid filter (``[grid]``, ``grid_on_run``).

    Args:
        run: the log, its beam geometry, start pose and sidecars (``load_run``; for a log file,
            ``slam_on_file``).
        config: every setting (``SlamConfig``, or the path of its TOML file; the defaults when None).
        progress: draw a progress bar.
        snapshot_every: keep a frame for an animation every that many observation updates (0: none).
        laser: corner FastSLAM's laser odometry of this log, if already matched (it does not depend
            on the filter's seed, so runs over several seeds can share it).
        on_update: ``on_update(record_index, filter)`` after every observation update (the
            ``FastSLAM`` or the ``GridSlam``), for a live view (``mazeslam.viz.live``); it must not
            change the filter.
    """
    if not isinstance(run, LoadedRun):
        raise TypeError(
            f"run_slam takes a LoadedRun (load_run(path)), got {type(run).__name__}; for a log file: slam_on_file(path)"
        )
    config = as_config(config)
    if on_update is not None:
        on_update = _unchecked(on_update)
    with numbers_checked(run, config):
        if config.map.kind == MapKind.GRID:
            return grid_on_run(run, config, progress, snapshot_every, on_update)
        return fastslam_on_run(run, config, progress, snapshot_every, laser, on_update)


def _unchecked(call):
    """``call`` with the warning filters it would have outside ``numbers_checked``: a live view's
    drawing may warn (matplotlib, an ellipse of a degenerate covariance) without its run failing."""

    def with_default_warnings(*args):
        with warnings.catch_warnings():
            warnings.simplefilter("default", RuntimeWarning)
            return call(*args)

    return with_default_warnings


class NumericalFailure(ValueError):
    """The filter's arithmetic failed (numpy: a singular matrix, eigenvalues that did not converge,
    a division by zero or an overflow): the settings do not fit the log. A ``ValueError``, so the
    command line prints it as one line."""


@contextmanager
def numbers_checked(run: LoadedRun, config: SlamConfig) -> Iterator[None]:
    """Meanwhile numpy's RuntimeWarnings (division by zero, overflow, invalid values) are errors,
    and they and numpy's linear-algebra errors leave as a ``NumericalFailure`` that says what they
    mean for the run and which settings to look at, never as a warning or a bare "Singular matrix"."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        try:
            yield
        except (np.linalg.LinAlgError, FloatingPointError, RuntimeWarning) as error:
            raise NumericalFailure(_failure_message(run, config, error)) from error


def _failure_message(run: LoadedRun, config: SlamConfig, error: Exception) -> str:
    """One line for a numerical failure of the filter ``config`` names on ``run``: what happened,
    numpy's words, the settings to check and the config that fits the log's kind (unless it is the
    one that failed)."""
    if config.map.kind == MapKind.GRID:
        check = "check [grid] motion_noise and [grid.match] against this log"
    else:
        check = settings_hint(config.fastslam)
    fits = SETTINGS[log_kind(run)]
    fitting = ""
    if fits is not None and f"configs/{fits}" not in check and _is_not(config, CONFIGS_FOLDER / fits):
        fitting = f"; {run.path.name} is {log_kind(run).value}: --config configs/{fits} fits it"
    return (
        f"{run.path}: the {config.map.kind.filter_name} diverged (numpy: {str(error) or type(error).__name__}: "
        f"a covariance or a weight went bad, the settings do not fit this log); {check}{fitting}"
    )


def _is_not(config: SlamConfig, path: Path) -> bool:
    """The config file ``path`` exists and holds other settings than ``config`` (the one that failed)."""
    return path.exists() and load_slam_config(path) != config


def slam_on_file(path: str | Path, config: SlamConfig | str | Path | None = None, progress: bool = True) -> SlamResult:
    """``run_slam`` on a log file, as ``mazeslam slam`` runs it: its sidecars read beside it,
    ``[sensor]`` applied, and the beam convention detected from its scans when neither says it
    (``with_detected_convention``). ``config``: a ``SlamConfig``, the path of its TOML file, or
    None: the config under configs/ that fits the log's kind (``log_kinds.chosen_config``; with
    ``progress``, its one line is printed to stderr, as the progress bar is)."""
    if config is None:
        choice = chosen_config(path)
        if progress:
            print(choice.line, file=sys.stderr)
        config = choice.config
    config = as_config(config)
    return run_slam(loaded_with_convention(path, config), config, progress)


def as_config(config: SlamConfig | str | Path | None) -> SlamConfig:
    """``config`` as a ``SlamConfig``: itself, read from the TOML file it names, or the defaults
    (None); anything else is a ``TypeError`` saying what is wanted."""
    if config is None or isinstance(config, SlamConfig):
        return config or SlamConfig()
    if isinstance(config, (str, Path)):
        return load_slam_config(config)
    raise TypeError(f"config must be a SlamConfig or the path of its TOML file, got {type(config).__name__}")
