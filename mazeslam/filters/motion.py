"""Motion from odometry: the exercise's ``predict_odo``, and dead reckoning.

The odometry reports, per record, the distance travelled ``dr`` and the heading change ``dth``
(the exercise's dX, dTheta). Every particle moves by the same increment with its own noise, drawn
in the increment's own terms (distance and turn), then composed with ``advance_pose``:

    dr'  = dr  + N(0, sigmaX^2 |dr|)
    dth' = dth + N(0, sigmaTH^2 |dth| + sigmaTH_drive^2 |dr|)

The variances grow with the motion, like wheel slip does (a random walk: after travelling d the
error has standard deviation proportional to sqrt(d)). The exercise adds a fixed amount per
record instead, so its cloud spreads even while the robot stands still; here a record that
reports no motion moves no particle.

Laser odometry (``mazeslam.filters.scan_matching``) reports whole poses ``(dx, dy, dth)`` in the
robot frame instead; ``predict_relative`` moves particles by those, with the same noise terms:
sigmaX along and across the heading, sigmaTH and sigmaTH_drive on the heading.
"""

from __future__ import annotations

import numpy as np

from mazeslam.geometry import advance_pose, compose
from mazeslam.log import CourseLog


def predict_odometry(poses: np.ndarray, distance: float, turn: float, sigma_x: float, sigma_th: float,
                     sigma_th_drive: float, rng: np.random.Generator) -> np.ndarray:
    """Particles ``poses`` (P, 3) moved by one odometry increment with motion-proportional noise.

    Args:
        distance, turn: the increment, metres and radians.
        sigma_x: distance noise, m per sqrt(m) travelled.
        sigma_th: heading noise from turning, rad per sqrt(rad) turned.
        sigma_th_drive: heading noise from driving, rad per sqrt(m) travelled.
        rng: the source of the noise (2 P normal draws per moving increment).
    Returns the new poses (P, 3), world frame.
    """
    if distance == 0.0 and turn == 0.0:
        return poses
    count = len(poses)
    distance_std = sigma_x * np.sqrt(abs(distance))
    turn_std = np.sqrt(sigma_th**2 * abs(turn) + sigma_th_drive**2 * abs(distance))
    noise = rng.standard_normal((2, count))
    return advance_pose(poses, distance + distance_std * noise[0], turn + turn_std * noise[1])


def relative_motion_covariance(increment: np.ndarray, sigma_x: float, sigma_th: float,
                               sigma_th_drive: float) -> np.ndarray:
    """Covariance (3, 3) of a relative motion ``increment`` (dx, dy, dth) in the robot frame it
    starts from: ``sigma_x^2 d`` along and across the heading, ``sigma_th^2 |dth| + sigma_th_drive^2 d``
    on the heading, d the distance travelled (m). Units as in ``predict_odometry``."""
    distance = float(np.hypot(increment[0], increment[1]))
    position = sigma_x**2 * distance
    return np.diag([position, position, sigma_th**2 * abs(increment[2]) + sigma_th_drive**2 * distance])


def predict_relative(poses: np.ndarray, increment: np.ndarray, covariance: np.ndarray,
                     rng: np.random.Generator) -> np.ndarray:
    """Particles ``poses`` (P, 3) moved by a relative motion ``increment`` (3,) (robot frame) with
    noise drawn from ``covariance`` (3, 3), one draw per particle. Returns the new poses (P, 3)."""
    noise = rng.multivariate_normal(np.zeros(3), covariance, size=len(poses), method="eigh")
    return compose(poses, np.asarray(increment, dtype=float) + noise)


def dead_reckoning(log: CourseLog, start_pose=(0.0, 0.0, 0.0)) -> np.ndarray:
    """Integrate the log's odometry from ``start_pose``: the pose (R, 3) at every record.

    A scan record gets the pose of the odometry before it. World frame; metres and radians.
    """
    poses = np.empty((len(log), 3))
    pose = np.asarray(start_pose, dtype=float)
    for index, (distance, turn) in enumerate(log.increments):
        pose = advance_pose(pose, distance, turn)
        poses[index] = pose
    return poses
