"""Motion from odometry: the deterministic part of the exercise's ``predict_odo``.

The noisy prediction that diffuses particles (FastSLAM) builds on ``advance_pose``; here lives
dead reckoning, the baseline every SLAM estimate is compared with.
"""

from __future__ import annotations

import numpy as np

from mazeslam.geometry import advance_pose
from mazeslam.log import CourseLog


def dead_reckoning(log: CourseLog, start_pose=(0.0, 0.0, 0.0)) -> np.ndarray:
    """Integrate the log's odometry from ``start_pose``: the pose (R, 3) at every record.

    A scan record gets the pose of the odometry before it. World frame; metres and radians.
    """
    increments = np.where(log.is_odometry[:, None], log.values[:, :2], 0.0)  # scans move nothing
    poses = np.empty((len(log), 3))
    pose = np.asarray(start_pose, dtype=float)
    for index, (distance, turn) in enumerate(increments):
        pose = advance_pose(pose, distance, turn)
        poses[index] = pose
    return poses
