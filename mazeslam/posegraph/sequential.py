"""Sequential edges: the laser odometry between consecutive scans, each with the covariance of its
own match.

The laser odometry (``mazeslam.registration.scan_matching.laser_odometry``) matches each scan to the
one before with a motion prior (the wheels, or constant velocity where a log has none). The
covariance of an interval is the match's posterior::

    Sigma = (H / variance_scale + P^-1)^-1 + floor^2 I

H the data term's Gauss-Newton Hessian at the match (``match_information``: the directions the
two scans fix, singular along a featureless corridor), P the prior's covariance (which supplies the
directions the scans do not fix), ``variance_scale`` the factor by which the data term's
independent-beam covariance understates the match's real error (beams of one scan are not
independent; ``SequentialParams``). An interval whose match was refused keeps the prior's mean and
covariance.
"""

from __future__ import annotations

import numpy as np

from mazeslam.core.beams import BeamGeometry
from mazeslam.data.log import CourseLog
from mazeslam.posegraph.params import SequentialParams
from mazeslam.registration.scan_matching import (
    LaserOdometry,
    ReferenceScan,
    ScanMatchParams,
    laser_odometry,
    match_information,
    scan_points,
)

#: Information added to a data term without a prior before inverting it (per unit: m^-2, rad^-2):
#: a direction the scans do not fix gets a standard deviation of 1e6, which the ``max_sigma`` test
#: refuses.
UNINFORMED = 1e-12


def posterior_covariance(information: np.ndarray, prior: np.ndarray | None, params: SequentialParams) -> np.ndarray:
    """``(H / variance_scale + P^-1)^-1 + floor^2 I`` (3, 3): a match's covariance from its data
    term's Hessian ``information`` (3, 3) and its prior's covariance ``prior`` (3, 3); without a
    prior (None), the data term's alone (``UNINFORMED`` where it fixes nothing)."""
    prior_information = UNINFORMED * np.eye(3) if prior is None else np.linalg.inv(prior)
    covariance = np.linalg.inv(information / params.variance_scale + prior_information)
    return 0.5 * (covariance + covariance.T) + params.floor**2 * np.eye(3)


def match_covariances(
    course_log: CourseLog,
    geometry: BeamGeometry,
    odometry: LaserOdometry,
    scan_params: ScanMatchParams,
    params: SequentialParams,
) -> np.ndarray:
    """The covariance (S, 3, 3) of each interval of ``odometry`` (module docstring): index k is the
    motion from scan k-1 to scan k in scan k-1's robot frame; index 0 (from the start) the prior's."""
    priors = odometry.priors(scan_params)[1]
    covariances = priors + params.floor**2 * np.eye(3)
    reference = None
    for index, record in enumerate(odometry.scan_records):
        points = scan_points(course_log.values[record], geometry, scan_params)
        if index and reference is not None and odometry.accepted[index]:
            information = match_information(reference, points, odometry.increments[index], scan_params)
            covariances[index] = posterior_covariance(information, priors[index], params)
        reference = ReferenceScan(points, scan_params) if len(points) >= scan_params.neighbours else None
    return 0.5 * (covariances + covariances.transpose(0, 2, 1))


def sequential_odometry(
    course_log: CourseLog, geometry: BeamGeometry, scan_params: ScanMatchParams, params: SequentialParams
) -> tuple[LaserOdometry, np.ndarray]:
    """The laser odometry of ``course_log`` and the covariance (S, 3, 3) of each of its intervals."""
    odometry = laser_odometry(course_log, geometry, scan_params)
    return odometry, match_covariances(course_log, geometry, odometry, scan_params, params)
