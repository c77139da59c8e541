"""Measure a log's odometry noise against its truth, in the units of the filter's motion model.

FastSLAM's motion model (``mazeslam.core.motion``) lets each odometry step of distance d and turn
dtheta err by variances that grow with the motion:

    var(distance error) = sigmaX^2 |d|
    var(heading error)  = sigmaTH^2 |dtheta| + sigmaTH_drive^2 |d|

Given a log and its true (or reference) pose at every record, this cuts the log into stretches
between consecutive observations (scans or landmark records: what the filter predicts across),
replays the odometry from the true pose at the start of each stretch, and compares where it lands
with the true pose at its end. Over all stretches, the along-track position error and the heading
error are fitted to the model by non-negative least squares:
``e_theta^2`` on ``(D, T)`` gives ``sigmaTH_drive^2`` and ``sigmaTH^2``; ``e_along^2`` on ``(D, T)``
gives ``sigmaX^2`` (the T term absorbs the small shift of the axle while turning on the spot, which
the filter's model leaves out). D and T are the stretch's summed |d| and |dtheta|.
Systematic errors (a wrong wheel radius) count as noise here, as they must for the filter.

Laser odometry (``mazeslam.registration.scan_matching``) is measured the same way, interval by interval
between scans (``laser_stretch_errors``): D and T are then the interval's matched distance and turn.

A few failed scan matches (metres or a right angle off) pull a least-squares fit far above the
error of a typical interval. ``fit_noise_trimmed`` fits again without the stretches whose error
lies beyond ``OUTLIER_SIGMAS`` standard deviations of the fit (with a floor on the standard
deviation, so that a stretch of almost no motion is not an outlier for an error of millimetres),
until none is left out anew: the noise of the matches that work, with the failures counted apart
(``MeasuredOdometryNoise.left_out``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from scipy.optimize import nnls

from mazeslam.core.geometry import relative, wrap_angle
from mazeslam.core.motion import OdometryNoise, dead_reckoning
from mazeslam.data.log import CourseLog
from mazeslam.registration.scan_matching import LaserOdometry


@dataclass(frozen=True)
class MeasuredOdometryNoise:
    """Odometry noise measured on a log, in the filter's units.

    Attributes:
        noise: the fitted sigmaX, sigmaTH, sigmaTH_drive.
        stretches: how many stretches between observations were used.
        distance: odometry distance they cover, m.
        turn: odometry turning they cover, rad.
        left_out: stretches left out of the fit as outliers (``fit_noise_trimmed``).
    """

    noise: OdometryNoise
    stretches: int
    distance: float
    turn: float
    left_out: int = 0


#: ``fit_noise_trimmed`` leaves out a stretch whose along-track or heading error lies beyond this
#: many of the fit's standard deviations (a normal error does so 0.5 % of the time).
OUTLIER_SIGMAS = 3.0


def stretch_errors(course_log: CourseLog, truth: np.ndarray) -> np.ndarray:
    """Odometry errors over each stretch between consecutive observations.

    Args:
        course_log: the log (R records).
        truth: (R, 3) true pose at every record, world frame (m, rad).

    Returns:
        (K, 4) rows ``[D, T, e_along, e_theta]``: summed |distance| (m) and |turn| (rad) of the
        stretch's odometry, the error along the direction travelled (m) and the heading error (rad)
        of the odometry replayed from the true pose at the stretch's start.
    """
    truth = np.asarray(truth, dtype=float)
    if truth.shape != (len(course_log), 3):
        raise ValueError(f"truth must hold one pose (x, y, theta) per record: {len(course_log)} x 3, got {truth.shape}")
    boundaries = np.flatnonzero(~course_log.is_odometry)
    if len(boundaries) < 2:
        raise ValueError("measuring the odometry noise needs a log with at least two observations (scans or landmarks)")
    reckoned = dead_reckoning(course_log, (0.0, 0.0, 0.0))
    increments = course_log.increments
    rows = []
    for start, end in zip(boundaries[:-1], boundaries[1:]):
        moved, turned = np.abs(increments[start + 1 : end + 1]).sum(axis=0)
        if moved == 0.0 and turned == 0.0:
            continue
        odometry_step = relative(reckoned[start], reckoned[end])
        rows.append(_error_row(moved, turned, odometry_step, relative(truth[start], truth[end])))
    return np.array(rows).reshape(-1, 4)


def laser_stretch_errors(laser: LaserOdometry, truth: np.ndarray) -> np.ndarray:
    """Laser odometry's errors over each interval between consecutive scans.

    Args:
        laser: the laser odometry of a log.
        truth: (S, 3) true pose at each of its scans, world frame (m, rad).

    Returns:
        (S - 1, 4) rows ``[D, T, e_along, e_theta]`` as in ``stretch_errors``, D and T the matched
        distance and turn.
    """
    truth = np.asarray(truth, dtype=float)
    if truth.shape != (len(laser.increments), 3):
        raise ValueError(f"truth must hold one pose per scan: {len(laser.increments)} x 3, got {truth.shape}")
    rows = [
        _error_row(math.hypot(step[0], step[1]), abs(step[2]), step, relative(truth[k - 1], truth[k]))
        for k, step in enumerate(laser.increments)
        if k
    ]
    return np.array(rows).reshape(-1, 4)


def _error_row(moved: float, turned: float, measured_step: np.ndarray, true_step: np.ndarray) -> tuple:
    """``(D, T, e_along, e_theta)`` of one stretch: the position error along the direction the
    measured step travelled (m) and the heading error (rad)."""
    heading = math.atan2(measured_step[1], measured_step[0]) if moved > 0 else 0.0
    along = (true_step[0] - measured_step[0]) * math.cos(heading) + (true_step[1] - measured_step[1]) * math.sin(
        heading
    )
    return moved, turned, along, wrap_angle(true_step[2] - measured_step[2])


def measure_odometry_noise(course_log: CourseLog, truth: np.ndarray) -> MeasuredOdometryNoise:
    """Fit the filter's odometry noise parameters to a log with truth (see the module docstring)."""
    return fit_noise(stretch_errors(course_log, truth))


def motion_stretch_errors(
    course_log: CourseLog, reference: np.ndarray, laser: LaserOdometry | None = None
) -> np.ndarray:
    """(K, 4) ``[D, T, e_along, e_theta]`` of whatever moves the filter, against ``reference``
    poses (R, 3) at every record (the truth, or a filter's path): the laser odometry's stretches
    (scan to scan) when given, else the odometry's (observation to observation)."""
    if laser is not None:
        return laser_stretch_errors(laser, np.asarray(reference)[laser.scan_records])
    return stretch_errors(course_log, reference)


def fit_noise(errors: np.ndarray) -> MeasuredOdometryNoise:
    """The noise parameters that fit the stretch errors (K, 4) ``[D, T, e_along, e_theta]`` by
    non-negative least squares (see the module docstring)."""
    moved, turned = errors[:, 0], errors[:, 1]
    along_coefficients, heading_coefficients = _variance_coefficients(errors)
    drive_var, turn_var = heading_coefficients
    noise = OdometryNoise(math.sqrt(along_coefficients[0]), math.sqrt(turn_var), math.sqrt(drive_var))
    return MeasuredOdometryNoise(noise, len(errors), float(moved.sum()), float(turned.sum()))


def fit_noise_trimmed(
    errors: np.ndarray, floor: float = 0.0, sigmas: float = OUTLIER_SIGMAS, rounds: int = 50
) -> MeasuredOdometryNoise:
    """``fit_noise`` of the stretch errors (K, 4) ``[D, T, e_along, e_theta]`` without their outliers:
    fit, leave out every stretch whose along-track or heading error lies beyond ``sigmas`` standard
    deviations of that fit (its variance ``a D + b T``, the least-squares coefficients, plus
    ``floor``^2: the smallest standard deviation, m and rad, an error is measured against; for
    laser odometry its matcher's ``prior_floor``), fit the rest, and so on until the stretches left
    out stop changing. Stretches, distance and turn are the kept ones'; ``left_out`` counts the
    others. Raises ValueError when ``rounds`` fits do not settle or nothing is left to fit."""
    motion, kept = errors[:, :2], np.ones(len(errors), dtype=bool)
    for _ in range(rounds):
        if not kept.any():
            raise ValueError("every stretch lies beyond the fit's spread: nothing is left to fit")
        along_coefficients, heading_coefficients = _variance_coefficients(errors[kept])
        inside = (errors[:, 2] ** 2 <= sigmas**2 * (motion @ along_coefficients + floor**2)) & (
            errors[:, 3] ** 2 <= sigmas**2 * (motion @ heading_coefficients + floor**2)
        )
        if (inside == kept).all():
            return replace(fit_noise(errors[kept]), left_out=int((~kept).sum()))
        kept = inside
    raise ValueError(f"the trimmed fit did not settle in {rounds} fits")


def _variance_coefficients(errors: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Non-negative ``(a, b)`` (2,) of the along-track and of the heading error's variance
    ``a D + b T`` that fit the stretch errors (K, 4) ``[D, T, e_along, e_theta]`` best."""
    moved, turned, along, heading = errors.T
    if not (moved > 0).any():
        raise ValueError("the log never drives: the distance noise cannot be measured")
    motion = np.column_stack([moved, turned])
    along_coefficients, _ = nnls(motion, along**2)  # turning on the spot also shifts the axle a little
    heading_coefficients, _ = nnls(motion, heading**2)
    return along_coefficients, heading_coefficients
