"""Planar geometry shared by every stage: angles, SE(2) poses, polar/cartesian points.

Conventions (docs/architecture.md): world frame X, Y in metres; heading theta in radians, wrapped to
(-pi, pi]; robot frame Xr forward, Yr left; bearings counter-clockwise from Xr.
A pose is an array ``(x, y, theta)``; arrays of poses are shaped ``(..., 3)`` and every function
broadcasts over the leading axes.
"""

from __future__ import annotations

import numpy as np

TWO_PI = 2.0 * np.pi


def wrap_angle(angle):
    """Wrap angles (radians, any shape) to the interval (-pi, pi]."""
    wrapped = np.pi - np.mod(np.pi - np.asarray(angle, dtype=float), TWO_PI)
    return wrapped if np.ndim(wrapped) else float(wrapped)


def compose(a, b):
    """SE(2) composition ``a ⊕ b``: pose ``b`` (given in the frame of ``a``) expressed in a's parent frame.

    ``a`` and ``b`` are ``(..., 3)`` arrays ``(x, y, theta)``; the result broadcasts over both.
    """
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    cos_a, sin_a = np.cos(a[..., 2]), np.sin(a[..., 2])
    x = a[..., 0] + cos_a * b[..., 0] - sin_a * b[..., 1]
    y = a[..., 1] + sin_a * b[..., 0] + cos_a * b[..., 1]
    return np.stack([x, y, wrap_angle(a[..., 2] + b[..., 2])], axis=-1)


def chained(start_pose, increments) -> np.ndarray:
    """Poses (N + 1, 3): ``start_pose`` (3,), then after each of ``increments`` (N, 3), composed one by
    one (``compose``), each in the frame of the pose before it."""
    poses = np.empty((len(increments) + 1, 3))
    poses[0] = start_pose
    for index, increment in enumerate(increments):
        poses[index + 1] = compose(poses[index], increment)
    return poses


def inverse(a):
    """SE(2) inverse ``⊖a``: the pose of the parent frame seen from ``a``. Shape ``(..., 3)``."""
    a = np.asarray(a, dtype=float)
    cos_a, sin_a = np.cos(a[..., 2]), np.sin(a[..., 2])
    x = -cos_a * a[..., 0] - sin_a * a[..., 1]
    y = sin_a * a[..., 0] - cos_a * a[..., 1]
    return np.stack([x, y, wrap_angle(-a[..., 2])], axis=-1)


def relative(a, b):
    """Pose ``b`` seen from pose ``a`` (``⊖a ⊕ b``), both given in the same frame. Shape ``(..., 3)``."""
    return compose(inverse(a), b)


def advance_pose(pose, distance, turn):
    """Move poses by an odometry increment, the exercise's (dr, dth), as a midpoint arc.

    The robot is taken to travel ``distance`` metres (negative: backwards) along the heading it has
    halfway through the turn, and to turn by ``turn`` radians. This is the standard odometry
    motion model (Thrun et al., Probabilistic Robotics, 5.4) with the two rotations set equal; for
    the short increments of a log it is exact to second order in ``turn``.

    ``pose`` is ``(..., 3)``; ``distance`` and ``turn`` broadcast against ``pose[..., 0]``.
    """
    pose = np.asarray(pose, dtype=float)
    heading = pose[..., 2] + 0.5 * np.asarray(turn, dtype=float)
    x = pose[..., 0] + distance * np.cos(heading)
    y = pose[..., 1] + distance * np.sin(heading)
    return np.stack([x, y, wrap_angle(pose[..., 2] + turn)], axis=-1)


def polar_to_cartesian(ranges, bearings):
    """Points at ``ranges`` (metres) along ``bearings`` (radians): array shaped ``(..., 2)``."""
    ranges = np.asarray(ranges, dtype=float)
    bearings = np.asarray(bearings, dtype=float)
    return np.stack([ranges * np.cos(bearings), ranges * np.sin(bearings)], axis=-1)


def cartesian_to_polar(points):
    """Range (metres) and bearing (radians, (-pi, pi]) of points shaped ``(..., 2)``."""
    points = np.asarray(points, dtype=float)
    return np.hypot(points[..., 0], points[..., 1]), np.arctan2(points[..., 1], points[..., 0])


def transform_points(pose, points):
    """Points ``(..., 2)`` given in the frame of ``pose`` ``(3,)``, expressed in the pose's parent frame."""
    pose = np.asarray(pose, dtype=float)
    points = np.asarray(points, dtype=float)
    cos_t, sin_t = np.cos(pose[2]), np.sin(pose[2])
    x = pose[0] + cos_t * points[..., 0] - sin_t * points[..., 1]
    y = pose[1] + sin_t * points[..., 0] + cos_t * points[..., 1]
    return np.stack([x, y], axis=-1)
