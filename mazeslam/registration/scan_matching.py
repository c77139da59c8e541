"""Laser odometry: the motion between consecutive scans, by matching each scan to the one before.

Point-to-line ICP (Censi 2008; Segal et al. 2009 in 3-D) with a motion prior: the pose ``x = (dx,
dy, dtheta)`` of the current scan in the previous scan's robot frame minimises

    sum_i  w_i (n_i . (R(x) p_i + t(x) - q_i))^2 / point_noise^2  +  (x - mu)^T P^-1 (x - mu)

where ``p_i`` is a point of the current scan, ``q_i`` its nearest point of the previous scan and
``n_i`` the normal of the previous scan's surface there (from its ``neighbours`` nearest points;
points not on a straight surface are not used), ``w_i`` a Huber weight, and ``(mu, P)`` the prior:
the wheel odometry between the two scans with its noise, or, where a log has no odometry for the
interval, the previous interval's motion (constant velocity) with a broad covariance. The prior
keeps the match where the scans alone cannot fix it: along a featureless corridor the points only
constrain the motion across it, and the odometry supplies the rest (the degenerate direction of
Zhang, Kaess and Singh 2016). Without odometry, an exhaustive correlative search over a window
around the prior (``mazeslam.registration.correlative``) seeds the refinement from its best few poses,
and the lowest objective wins. A match that overlaps the previous scan too little is rejected: the prior's mean is
used instead and the interval is flagged.

Scan points are in the sensor frame of each scan; the sensor's mounting offset is taken into
account, so increments are robot poses (metres, radians), like odometry's.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from mazeslam.core.beams import BeamGeometry
from mazeslam.core.config import require
from mazeslam.core.geometry import advance_pose, chained, wrap_angle
from mazeslam.core.motion import OdometryNoise
from mazeslam.data.log import CourseLog
from mazeslam.registration.correlative import CorrelativeParams, LikelihoodGrid, correlative_candidates


@dataclass(frozen=True)
class ScanMatchParams:
    """Settings of the laser odometry (TOML section ``[scan_matching]``).

    Attributes:
        enabled: the filter moves by laser odometry instead of the log's odometry records.
        point_noise: standard deviation of a point's distance to the matched surface, m.
        min_range, max_range: returns used, m (0 = no return is always left out).
        neighbours: points that define a surface normal.
        max_flatness: a point's neighbourhood is a straight surface when the smaller eigenvalue of
            its scatter is at most this fraction of the larger.
        correspondence_distances: the nearest point must be this close (m), one value per stage of
            ``iterations_per_stage`` iterations, tightening from coarse to fine.
        iterations_per_stage: Gauss-Newton iterations at each correspondence distance.
        min_overlap: a match is accepted when at least this fraction of the current scan's points
            lies within the last correspondence distance of the previous scan.
        odometry_prior: the prior's noise from wheel odometry (``[scan_matching.odometry_prior]``,
            the terms of ``[fastslam]``: sigmaX m/sqrt(m), sigmaTH rad/sqrt(rad), sigmaTH_drive
            rad/sqrt(m)); wider than the filter's, as the match only needs a starting point.
        prior_floor: smallest prior standard deviation, m and rad (a robot that reports no motion
            may still have moved a little).
        blind_sigma_xy, blind_sigma_th: the constant-velocity prior's standard deviation where a log
            has no odometry for an interval, m and rad.
        correlative: the search that seeds the match without odometry (``[scan_matching.correlative]``).
    """

    enabled: bool = False
    point_noise: float = 0.03
    min_range: float = 0.05
    max_range: float = 20.0
    neighbours: int = 6
    max_flatness: float = 0.1
    correspondence_distances: tuple = (1.0, 0.5, 0.3, 0.2)
    iterations_per_stage: int = 5
    min_overlap: float = 0.5
    odometry_prior: OdometryNoise = field(default_factory=lambda: OdometryNoise(0.05, 0.1, 0.05))
    prior_floor: float = 0.01
    blind_sigma_xy: float = 1.0
    blind_sigma_th: float = 0.7
    correlative: CorrelativeParams = field(default_factory=CorrelativeParams)

    def __post_init__(self):
        object.__setattr__(self, "correspondence_distances", tuple(self.correspondence_distances))
        require(self.point_noise > 0, "point_noise must be positive (m)")
        require(0 <= self.min_range < self.max_range, "need 0 <= min_range < max_range (m)")
        require(
            3 <= self.neighbours <= 1000, f"neighbours must be in 3..1000 to define a surface, got {self.neighbours}"
        )
        require(0 < self.max_flatness <= 1, "max_flatness must be in (0, 1]")
        require(
            len(self.correspondence_distances) > 0 and all(d > 0 for d in self.correspondence_distances),
            "correspondence_distances must be positive distances (m)",
        )
        require(
            1 <= self.iterations_per_stage <= 1000,
            f"iterations_per_stage must be in 1..1000, got {self.iterations_per_stage}",
        )
        require(len(self.correspondence_distances) <= 100, "correspondence_distances: at most 100 stages")
        require(0 <= self.min_overlap <= 1, "min_overlap must be a fraction in [0, 1]")
        require(
            self.prior_floor > 0 and self.blind_sigma_xy > 0 and self.blind_sigma_th > 0,
            "prior_floor, blind_sigma_xy and blind_sigma_th must be positive",
        )


class ReferenceScan:
    """A scan to match against: its points (N, 2), the unit normal (N, 2) of the surface at each
    point, whether that surface is straight (N,), and the points sorted into buckets for the
    nearest-neighbour queries (``mazeslam.registration.kernels.buckets``)."""

    def __init__(self, points: np.ndarray, params: ScanMatchParams):
        from mazeslam.registration import kernels  # here: numba loads only where scans are matched

        self.points = np.ascontiguousarray(points, dtype=float)
        self.buckets = kernels.buckets(self.points)
        neighbours = min(params.neighbours, len(self.points))
        self.normals, self.straight = kernels.surface_normals(
            self.points, self.buckets, neighbours, params.max_flatness
        )

    @property
    def kernel_reference(self) -> tuple:
        """The scan as the kernels take it: ``(points, normals, straight, buckets)``."""
        return self.points, self.normals, self.straight, self.buckets


@dataclass(frozen=True)
class Match:
    """The pose (3,) of a scan in the previous scan's robot frame, the objective at it and the
    fraction of its points within the final correspondence distance of the previous scan."""

    pose: np.ndarray
    objective: float
    overlap: float


def _data_scale(points: np.ndarray, params: ScanMatchParams) -> float:
    """Weight of a squared residual (m^2) in the objective: 1 / point_noise^2, scaled to 100 points."""
    return 100.0 / max(len(points), 1) / params.point_noise**2


def _prior_offset(pose: np.ndarray, prior: np.ndarray) -> np.ndarray:
    """``pose - prior`` (3,) with the heading difference wrapped."""
    offset = pose - prior
    offset[2] = wrap_angle(offset[2])
    return offset


def match_scan(
    reference: ReferenceScan,
    points: np.ndarray,
    prior: np.ndarray,
    prior_covariance: np.ndarray,
    params: ScanMatchParams,
    start: np.ndarray | None = None,
) -> Match:
    """Gauss-Newton on the objective in the module docstring from ``start`` (default the prior),
    ``iterations_per_stage`` steps at each of ``correspondence_distances``
    (``mazeslam.registration.kernels.refine``).

    ``points`` (K, 2) are the current scan's returns in the robot frame; ``prior`` (3,) and
    ``prior_covariance`` (3, 3) the motion prior. The data term is scaled to 100 points, so that
    the prior weighs the same whatever the beam count.
    """
    from mazeslam.registration import kernels  # here: numba loads only where scans are matched

    points = np.ascontiguousarray(points, dtype=float)
    prior = np.asarray(prior, dtype=float)
    prior_information = np.linalg.inv(prior_covariance)
    pose = kernels.refine(
        reference.kernel_reference,
        points,
        prior,
        prior_information,
        np.array(prior if start is None else start, dtype=float),
        np.asarray(params.correspondence_distances, dtype=float),
        params.iterations_per_stage,
        _data_scale(points, params),
        params.point_noise,
    )
    return _score(reference, points, pose, prior, prior_information, params)


def match_information(
    reference: ReferenceScan, points: np.ndarray, pose: np.ndarray, params: ScanMatchParams
) -> np.ndarray:
    """The data term's Gauss-Newton Hessian (3, 3) at ``pose`` (3,): the information the points
    (K, 2) (robot frame) give on the pose, without the prior, in ``match_scan``'s units (residuals
    of ``point_noise``, scaled to 100 points; 1/m^2, 1/(m rad), 1/rad^2).

    Pairs within the last correspondence distance on a straight surface count, with their Huber
    weight, as in the last iteration of ``match_scan``. Along a featureless corridor it is singular in
    the corridor's direction (Censi 2007's covariance of ICP, the part the data can fix)."""
    from mazeslam.registration import kernels  # here: numba loads only where scans are matched

    points = np.ascontiguousarray(points, dtype=float)
    last = params.correspondence_distances[-1]
    pose = np.asarray(pose, dtype=float)
    return kernels.information(
        reference.kernel_reference, points, pose, last, _data_scale(points, params), params.point_noise
    )


def _score(
    reference: ReferenceScan,
    points: np.ndarray,
    pose: np.ndarray,
    prior: np.ndarray,
    prior_information: np.ndarray,
    params: ScanMatchParams,
) -> Match:
    """The objective with a point that has no partner within the final correspondence distance
    costing as much as one that far from its surface, and the overlap (the fraction that has one)."""
    from mazeslam.registration import kernels  # here: numba loads only where scans are matched

    data, overlap = kernels.score(reference.kernel_reference, points, pose, params.correspondence_distances[-1])
    offset = _prior_offset(pose, prior)
    return Match(pose, float(data * _data_scale(points, params) + offset @ prior_information @ offset), float(overlap))


@dataclass
class LaserOdometry:
    """The motion between consecutive scans of a log.

    Attributes:
        scan_records: (S,) record numbers of the scans in the log.
        increments: (S, 3) pose of each scan in the previous scan's robot frame (dx, dy, dtheta;
            metres, radians); the first scan's is the wheel odometry from the log's start.
        wheel_increments: (S, 3) the same from the log's odometry records (zero where none).
        had_odometry: (S,) the log has odometry records for the interval before the scan.
        accepted: (S,) the match was accepted (else the increment is the prior's mean).
        overlap: (S,) fraction of the scan's points matched to the previous scan.
    """

    scan_records: np.ndarray
    increments: np.ndarray
    wheel_increments: np.ndarray
    had_odometry: np.ndarray
    accepted: np.ndarray
    overlap: np.ndarray

    def poses(self, start_pose) -> np.ndarray:
        """The increments chained from ``start_pose``: the pose (S, 3) of every scan, world frame."""
        return chained(start_pose, self.increments)[1:]

    def priors(self, params: ScanMatchParams) -> tuple[np.ndarray, np.ndarray]:
        """The motion prior (S, 3) and its covariance (S, 3, 3) each interval's match had with
        ``params`` (``motion_prior``; the first interval's, from the start, as it would have)."""
        previous = [None, None, *self.increments[1:-1]]  # the motion before each interval, matched
        pairs = [
            motion_prior(wheel, had, before, params)
            for wheel, had, before in zip(self.wheel_increments, self.had_odometry, previous)
        ]
        return np.array([p for p, _ in pairs]).reshape(-1, 3), np.array([c for _, c in pairs]).reshape(-1, 3, 3)


def scan_points(ranges: np.ndarray, geometry: BeamGeometry, params: ScanMatchParams) -> np.ndarray:
    """A scan's returns within the range limits as points (K, 2) in the robot frame, metres."""
    return geometry.returns(ranges, params.min_range, params.max_range)


def wheel_motion(course_log: CourseLog, first: int | np.integer, last: int | np.integer) -> tuple[np.ndarray, bool]:
    """The odometry records after record ``first`` up to ``last`` chained: the motion (3,) in the
    robot frame at ``first`` (at the start pose for ``first = -1``), and whether there was any."""
    pose = np.zeros(3)
    rows = np.arange(first + 1, last + 1)
    rows = rows[course_log.is_odometry[rows]]
    for distance, turn in course_log.values[rows, :2]:
        pose = advance_pose(pose, distance, turn)
    return pose, bool(len(rows))


def odometry_prior_covariance(motion: np.ndarray, params: ScanMatchParams) -> np.ndarray:
    """Covariance (3, 3) of a wheel-odometry motion (dx, dy, dtheta) under the prior's noise
    (``OdometryNoise.relative_covariance``), at least ``prior_floor`` in each term."""
    return params.odometry_prior.relative_covariance(motion) + params.prior_floor**2 * np.eye(3)


def motion_prior(
    wheel: np.ndarray, has_odometry: bool, previous_motion: np.ndarray | None, params: ScanMatchParams
) -> tuple[np.ndarray, np.ndarray]:
    """The prior (3,) of an interval's match and its covariance (3, 3): the wheels' motion ``wheel``
    under ``odometry_prior`` where the log has odometry for the interval, else the motion before it
    (``previous_motion``: constant velocity; none before the first) with the ``blind_sigma_*``."""
    if has_odometry:
        return wheel, odometry_prior_covariance(wheel, params)
    prior = previous_motion if previous_motion is not None else np.zeros(3)
    return prior, np.diag([params.blind_sigma_xy**2, params.blind_sigma_xy**2, params.blind_sigma_th**2])


def laser_odometry(course_log: CourseLog, geometry: BeamGeometry, params: ScanMatchParams) -> LaserOdometry:
    """Match every scan of ``course_log`` to the one before it (see the module docstring)."""
    records = np.flatnonzero(course_log.is_scan)
    count = len(records)
    increments, wheels = np.zeros((count, 3)), np.zeros((count, 3))
    had_odometry, accepted, overlap = np.zeros(count, bool), np.zeros(count, bool), np.zeros(count)
    reference = previous_motion = None
    for index, record in enumerate(records):
        points = scan_points(course_log.values[record], geometry, params)
        wheels[index], had_odometry[index] = wheel_motion(course_log, records[index - 1] if index else -1, record)
        if index:
            increments[index], accepted[index], overlap[index] = _interval(
                reference, points, wheels[index], had_odometry[index], previous_motion, params
            )
            previous_motion = increments[index]
        else:  # nothing to match the first scan to: the odometry from the start pose
            increments[index] = wheels[index]
        reference = ReferenceScan(points, params) if len(points) >= params.neighbours else None
    return LaserOdometry(records, increments, wheels, had_odometry, accepted, overlap)


def _interval(
    reference: ReferenceScan | None,
    points: np.ndarray,
    wheel: np.ndarray,
    has_odometry: bool,
    previous_motion: np.ndarray | None,
    params: ScanMatchParams,
) -> tuple[np.ndarray, bool, float]:
    """The increment of one interval, whether its match was accepted, and the match's overlap."""
    prior, covariance = motion_prior(wheel, has_odometry, previous_motion, params)
    if reference is None or len(points) < params.neighbours:
        return prior, False, 0.0
    best = match_scan(reference, points, prior, covariance, params)
    if not has_odometry:
        grid = LikelihoodGrid(reference.points, params.correlative)
        for start in correlative_candidates(grid, points, prior, covariance, params.correlative):
            candidate = match_scan(reference, points, prior, covariance, params, start)
            if candidate.objective < best.objective:
                best = candidate
    if best.overlap < params.min_overlap:
        return prior, False, best.overlap
    return best.pose, True, best.overlap
