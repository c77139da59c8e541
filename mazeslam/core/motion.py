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

Laser odometry (``mazeslam.registration.scan_matching``) reports whole poses ``(dx, dy, dth)`` in the
robot frame instead; ``predict_relative`` moves particles by those, with the same noise terms:
sigmaX along and across the heading, sigmaTH and sigmaTH_drive on the heading.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from mazeslam.core.config import require
from mazeslam.core.geometry import advance_pose, compose, relative

if TYPE_CHECKING:
    from mazeslam.data.log import CourseLog


@dataclass(frozen=True)
class OdometryNoise:
    """How uncertain an odometry increment is; named as in the exercise's control_panel.m.

    Attributes:
        sigmaX: distance noise, m per sqrt(m) travelled.
        sigmaTH: heading noise from turning, rad per sqrt(rad) turned.
        sigmaTH_drive: heading noise from driving, rad per sqrt(m) travelled.
    """

    sigmaX: float
    sigmaTH: float
    sigmaTH_drive: float

    def __post_init__(self):
        for name in ("sigmaX", "sigmaTH", "sigmaTH_drive"):
            require(0 <= getattr(self, name) <= 10, f"{name} must be in [0, 10], got {getattr(self, name)}")

    def inflated(self, factor: float) -> OdometryNoise:
        """This noise with every variance multiplied by ``factor``."""
        root = factor**0.5
        return OdometryNoise(root * self.sigmaX, root * self.sigmaTH, root * self.sigmaTH_drive)

    def increment_covariance(self, distance: float, turn: float) -> np.ndarray:
        """Covariance (2, 2) of an odometry increment (distance m, turn rad): diagonal,
        ``sigmaX^2 |d|`` and ``sigmaTH^2 |turn| + sigmaTH_drive^2 |d|``."""
        return np.diag(
            [self.sigmaX**2 * abs(distance), self.sigmaTH**2 * abs(turn) + self.sigmaTH_drive**2 * abs(distance)]
        )

    def relative_covariance(self, increment: np.ndarray) -> np.ndarray:
        """Covariance (3, 3) of a relative motion ``increment`` (dx, dy, dth) in the robot frame it
        starts from: ``sigmaX^2 d`` along and across the heading, ``sigmaTH^2 |dth| + sigmaTH_drive^2 d``
        on the heading, d the distance travelled (m)."""
        distance = float(np.hypot(increment[0], increment[1]))
        position = self.sigmaX**2 * distance
        return np.diag([position, position, self.sigmaTH**2 * abs(increment[2]) + self.sigmaTH_drive**2 * distance])


def predict_odometry(
    poses: np.ndarray, distance: float, turn: float, noise: OdometryNoise, rng: np.random.Generator
) -> np.ndarray:
    """Particles ``poses`` (P, 3) moved by one odometry increment with motion-proportional noise.

    Args:
        distance, turn: the increment, metres and radians.
        noise: the increment's noise model.
        rng: the source of the noise (2 P normal draws per moving increment).
    Returns the new poses (P, 3), world frame.
    """
    if distance == 0.0 and turn == 0.0:
        return poses
    variances = np.diag(noise.increment_covariance(distance, turn))
    draws = rng.standard_normal((2, len(poses))) * np.sqrt(variances)[:, None]
    return advance_pose(poses, distance + draws[0], turn + draws[1])


def predict_relative(
    poses: np.ndarray, increment: np.ndarray, covariance: np.ndarray, rng: np.random.Generator
) -> np.ndarray:
    """Particles ``poses`` (P, 3) moved by a relative motion ``increment`` (3,) (robot frame) with
    noise drawn from ``covariance`` (3, 3), one draw per particle. Returns the new poses (P, 3)."""
    noise = rng.multivariate_normal(np.zeros(3), covariance, size=len(poses), method="eigh")
    return compose(poses, np.asarray(increment, dtype=float) + noise)


def dead_reckoning(log: CourseLog, start_pose=(0.0, 0.0, 0.0), left_out=()) -> np.ndarray:
    """Integrate the log's odometry from ``start_pose``: the pose (R, 3) at every record, the
    odometry records ``left_out`` (indices: glitches) moving nothing.

    A scan record gets the pose of the odometry before it. World frame; metres and radians.
    """
    increments = log.increments
    increments[np.asarray(left_out, dtype=int)] = 0.0
    poses = np.empty((len(log), 3))
    pose = np.asarray(start_pose, dtype=float)
    for index, (distance, turn) in enumerate(increments):
        pose = advance_pose(pose, distance, turn)
        poses[index] = pose
    return poses


def carried_to_records(
    scan_records: np.ndarray,
    scan_poses: np.ndarray,
    scan_covariances: np.ndarray,
    reckoned: np.ndarray,
    reckoned_start: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Poses (R, 3) and covariances (R, 3, 3) at every record from the poses (S, 3) and covariances
    (S, 3, 3) at the scans, records ``scan_records`` (S,): a record gets the pose of the last scan at or
    before it moved on by the odometry since, ``reckoned`` (R, 3) (the odometry at every record's time,
    from ``reckoned_start`` (3,); the start pose moved so before the first scan, with zero
    covariance), and the covariance of that scan. World frame, m and rad."""
    anchor = np.searchsorted(scan_records, np.arange(len(reckoned)), side="right")  # 0: before any scan
    start = np.asarray(reckoned_start, dtype=float)[None]
    anchor_pose = np.vstack([start, scan_poses])[anchor]
    anchor_reckoned = np.vstack([start, reckoned[scan_records]])[anchor]
    covariances = np.concatenate([np.zeros((1, 3, 3)), scan_covariances])[anchor]
    return compose(anchor_pose, relative(anchor_reckoned, reckoned)), covariances
