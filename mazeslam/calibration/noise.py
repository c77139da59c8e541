"""Measure a log's noise from the log itself, in the units of the filter's settings.

``calibrate`` measures the three noises FastSLAM needs and says against what: the truth beside a
simulated (or referenced) log, else the filter's own path and map, which needs no truth:

* the laser's range noise, from the walls' scatter (below; no truth, no motion needed);
* the odometry's (or laser odometry's) noise, stretch by stretch between observations
  (``odometry_noise``);
* the corner observations' noise, from repeated observations of the same landmarks: each
  observation's residual against the landmark it most likely is, seen from the reference pose,
  fitted to ``observation_scale`` x the extractor's covariance + diag(sigmaR^2, sigmaB^2).

Range noise of the laser: every extracted wall is straight, so the scatter of its points around the
fitted line is the range noise seen across the wall. A point at bearing b on a line with normal
angle alpha is off the line by ``d = e cos(b - alpha)`` for a range error e, so ``e = d / cos(b - alpha)``.
Pooled over all lines (each fit uses two degrees of freedom), with beams within 60 degrees of the
wall's normal so the division does not amplify the line's own fit error:

    sigma^2 = sum_i e_i^2 / sum_lines (n - 2)

It needs no truth and no motion: only straight walls.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import nnls

from mazeslam.calibration.odometry_noise import MeasuredOdometryNoise, fit_noise, motion_stretch_errors
from mazeslam.core.config import with_settings
from mazeslam.data import log
from mazeslam.data.loaded_run import LoadedRun
from mazeslam.fastslam import ekf
from mazeslam.fastslam.identities import identities_along
from mazeslam.features.corners import CornerExtractor
from mazeslam.pipeline import MapKind, run_slam
from mazeslam.registration.scan_matching import laser_odometry

#: Beams hitting a wall farther than this from its normal are left out (their range errors are
#: poorly seen across the wall), radians.
MAX_INCIDENCE = math.radians(60.0)


@dataclass(frozen=True)
class RangeNoise:
    """The laser's range noise measured on straight walls.

    Attributes:
        std: standard deviation of a range, metres.
        points: how many returns it was measured on; lines: on how many lines.
    """

    std: float
    points: int
    lines: int


def laser_range_noise(scans: np.ndarray, extractor: CornerExtractor) -> RangeNoise:
    """The range noise (see the module docstring) of ``scans`` (S, N) ranges in metres (0: no
    return), taken with ``extractor``'s beam geometry and line settings."""
    squared, dof, points, lines = 0.0, 0, 0, 0
    for ranges in scans:
        features = extractor.extract(ranges)
        bearings = extractor.bearings[features.beams]
        for segment in features.segments:
            span = slice(segment.first, segment.last + 1)
            incidence = np.cos(bearings[span] - segment.alpha)
            offsets = features.points[span] @ segment.normal - segment.r
            facing = np.abs(incidence) >= math.cos(MAX_INCIDENCE)
            if facing.sum() < 3:
                continue
            errors = offsets[facing] / incidence[facing]
            squared += float(errors @ errors)
            dof += int(facing.sum()) - 2
            points += int(facing.sum())
            lines += 1
    if dof <= 0:
        raise ValueError("no straight walls in the scans: the range noise cannot be measured")
    return RangeNoise(math.sqrt(squared / dof), points, lines)


def pooled_range_noise(measured: Sequence[RangeNoise]) -> RangeNoise:
    """One range noise from several logs' (``laser_range_noise``): the variance pooled over all
    their lines, each line weighing by its degrees of freedom (points - 2); one log's as measured."""
    if len(measured) == 1:
        return measured[0]
    dof = [noise.points - 2 * noise.lines for noise in measured]
    variance = sum(noise.std**2 * n for noise, n in zip(measured, dof)) / sum(dof)
    return RangeNoise(math.sqrt(variance), sum(n.points for n in measured), sum(n.lines for n in measured))


@dataclass(frozen=True)
class ObservationNoise:
    """The noise of observations, in the filter's terms: a corner observation's covariance is
    ``kind_scales[kind]`` times the one the line fits give (``[corners] covariance_scale``), plus
    diag(sigmaR^2, sigmaB^2) (``[fastslam]``; all of it for landmark records, which come without
    a covariance).

    Attributes:
        kind_scales: per kind, width x (1 + rho) / (1 - rho): ``widths[kind]`` how the fits'
            covariance compares with the scatter, ``correlations[kind]`` rho the correlation of one
            landmark's normalised errors from one scan to the next.
        sigmaR: range noise beyond the fits' covariance, metres.
        sigmaB: bearing noise beyond it, radians.
        observations: how many observations it was measured on.
    """

    kind_scales: dict[str, float]
    widths: dict[str, float]
    correlations: dict[str, float]
    sigmaR: float
    sigmaB: float
    observations: int


@dataclass(frozen=True)
class Residuals:
    """Observations against the landmarks they most likely are (``observation_residuals``).

    Attributes:
        errors: (A, 2) z - h(pose, landmark): range (m) and bearing (rad).
        covariances: (A, 2, 2) the covariance the extractor reported (zeros for landmark records).
        kinds: (A,) the observations' kinds ("landmark" for landmark records).
        landmarks: (A,) which landmark each is; updates: (A,) the number of the update it came in.
    """

    errors: np.ndarray
    covariances: np.ndarray
    kinds: np.ndarray
    landmarks: np.ndarray
    updates: np.ndarray


def pooled_residuals(parts: Sequence[Residuals]) -> Residuals:
    """Several logs' residuals as one: landmarks and updates numbered apart per log, so that no
    landmark of one log is taken for another's and no update follows one of another log."""
    landmark_offset, update_offset, shifted = 0, 0, []
    for part in parts:
        shifted.append(
            Residuals(
                part.errors,
                part.covariances,
                part.kinds,
                part.landmarks + landmark_offset,
                part.updates + update_offset,
            )
        )
        landmark_offset += int(part.landmarks.max(initial=-1)) + 1
        update_offset += int(part.updates.max(initial=-1)) + 2
    return Residuals(
        *(np.concatenate([getattr(p, field.name) for p in shifted]) for field in dataclasses.fields(Residuals))
    )


def observations_by_record(run: LoadedRun, extractor: CornerExtractor | None):
    """Yield ``(record index, z (K, 2), covariances (K, 2, 2), kinds (K,))`` for every scan (its
    corners with the extractor's covariances) and every landmark record (zero covariance)."""
    for record in run.log.records():
        if isinstance(record, log.ScanRecord):
            assert extractor is not None  # None only for a log without scans
            features = extractor.extract(record.ranges)
            yield (
                record.index,
                features.observation_array(),
                features.observation_covariances(),
                [o.kind for o in features.observations],
            )
        elif isinstance(record, log.LandmarkRecord):
            yield record.index, np.array([[record.range, record.bearing]]), np.zeros((1, 2, 2)), ["landmark"]


def observation_residuals(
    run: LoadedRun, extractor: CornerExtractor | None, poses: np.ndarray, landmarks: np.ndarray, radius: float
) -> Residuals:
    """Every observation's innovation against the landmark it most likely is: the nearest to where
    the pose puts it, within ``radius`` metres (farther ones are left out).

    Args:
        run: the loaded log.
        extractor: its corner extractor (None for a log without scans).
        poses: (R, 3) the robot pose at every record (the truth, or a filter's path).
        landmarks: (L, 2) where the landmarks are (the true corners, or a filter's map), metres.
        radius: metres (the ``[evaluation] match_radius``).
    """
    rows = []
    identify = identities_along(poses, landmarks, radius)
    for update, (record, observed_all, covariance_all, kinds) in enumerate(observations_by_record(run, extractor)):
        if not len(observed_all):
            continue
        named = identify(record, observed_all)
        for k in np.flatnonzero(named >= 0):
            predicted, _, _ = ekf.range_bearing(poses[record][None], landmarks[named[k]][None])
            rows.append(
                (ekf.innovation(observed_all[k], predicted[0]), covariance_all[k], kinds[k], int(named[k]), update)
            )
    if not rows:
        return Residuals(
            np.empty((0, 2)), np.empty((0, 2, 2)), np.empty(0, dtype=str), np.empty(0, int), np.empty(0, int)
        )
    errors, covariances, kinds, which, updates = zip(*rows)
    return Residuals(np.array(errors), np.array(covariances), np.array(kinds), np.array(which), np.array(updates))


def fit_observation_noise(residuals: Residuals) -> ObservationNoise:
    """The ``ObservationNoise`` that explains ``residuals``.

    1. Widths and the extra terms: non-negative least squares of each squared error on the
       covariance's diagonal entry for its kind (one column per kind that has covariances) and a
       constant (sigmaR^2 for ranges, sigmaB^2 for bearings), each component's rows divided by its
       median variance so that metres and radians weigh alike.
    2. Correlations: of the errors (normalised by the fits' standard deviations) of one landmark
       seen as the same kind in two consecutive updates, range and bearing pooled; clipped to
       [0, 0.95].
    """
    errors, covariances, kinds = residuals.errors, residuals.covariances, residuals.kinds
    if len(errors) < 10:
        raise ValueError(f"only {len(errors)} observations matched a landmark: too few to measure their noise")
    with_covariance = sorted({kind for kind, c in zip(kinds, covariances) if c[0, 0] > 0 and c[1, 1] > 0})
    count = len(errors)
    variances = np.stack([covariances[:, 0, 0], covariances[:, 1, 1]])  # (2, A)
    units = [np.median(v[v > 0]) if (v > 0).any() else np.mean(errors[:, c] ** 2) for c, v in enumerate(variances)]
    design = np.zeros((2 * count, len(with_covariance) + 2))
    for column, kind in enumerate(with_covariance):
        design[:count, column] = np.where(kinds == kind, variances[0], 0.0) / units[0]
        design[count:, column] = np.where(kinds == kind, variances[1], 0.0) / units[1]
    design[:count, -2], design[count:, -1] = 1.0 / units[0], 1.0 / units[1]
    target = np.concatenate([errors[:, 0] ** 2 / units[0], errors[:, 1] ** 2 / units[1]])
    solution, _ = nnls(design, target)
    widths = {kind: float(width) for kind, width in zip(with_covariance, solution)}
    correlations = {kind: _repeat_correlation(residuals, kind) for kind in with_covariance}
    scales = {kind: widths[kind] * (1 + rho) / (1 - rho) for kind, rho in correlations.items()}
    return ObservationNoise(scales, widths, correlations, math.sqrt(solution[-2]), math.sqrt(solution[-1]), count)


def _repeat_correlation(residuals: Residuals, kind: str) -> float:
    """Correlation of the normalised errors of one landmark seen as ``kind`` in consecutive
    updates (range and bearing pooled), clipped to [0, 0.95]; 0 with fewer than 10 pairs."""
    chosen = np.flatnonzero(residuals.kinds == kind)
    normalised = residuals.errors[chosen] / np.sqrt(np.diagonal(residuals.covariances[chosen], axis1=1, axis2=2))
    seen = {(int(residuals.landmarks[i]), int(residuals.updates[i])): n for n, i in enumerate(chosen)}
    pairs = [
        (normalised[seen[(landmark, update - 1)]], normalised[n])
        for (landmark, update), n in seen.items()
        if (landmark, update - 1) in seen
    ]
    if len(pairs) < 10:
        return 0.0
    before, after = (np.concatenate(side) for side in zip(*pairs))
    return float(np.clip(np.corrcoef(before, after)[0, 1], 0.0, 0.95))


@dataclass(frozen=True)
class Calibration:
    """What ``calibrate`` (or ``calibrate_logs``) measured on one log (or several).

    Attributes:
        source: the log (or the logs); reference: what the residuals were taken against ("truth" or "the
            filter's path and map").
        range_noise: the laser's (None for a log without scans).
        motion: the odometry's (or laser odometry's) noise; motion_source names which, against what.
        observations: the corner (or landmark) observations' noise; None when too few observations
            matched a landmark (observation_problem says why).
    """

    source: str
    reference: str
    range_noise: RangeNoise | None
    motion: MeasuredOdometryNoise
    motion_source: str
    observations: ObservationNoise | None
    observation_problem: str = ""

    def settings(self) -> list[str]:
        """The measured settings as TOML lines, each saying where its number comes from."""
        noise, seen = self.motion.noise, self.observations
        where = f"measured by mazeslam calibrate on {self.source} against {self.reference}"
        lines = [
            f"# {where}",
            "[fastslam]",
            f"sigmaX = {noise.sigmaX:.4g}             # m per sqrt(m): {self.motion_source}, "
            f"{self.motion.stretches} stretches, {self.motion.distance:.2f} m",
            f"sigmaTH = {noise.sigmaTH:.4g}            # rad per sqrt(rad) turned ({self.motion.turn:.1f} rad)",
            f"sigmaTH_drive = {noise.sigmaTH_drive:.4g}      # rad per sqrt(m) driven",
        ]
        if seen is None:
            lines.append(f"# observation noise not measured: {self.observation_problem}")
        else:
            lines += [
                f"sigmaR = {seen.sigmaR:.3g}             # m: range noise beyond the corners' covariance "
                f"({seen.observations} observations)",
                f"sigmaB = {seen.sigmaB:.3g}             # rad: bearing noise beyond it",
            ]
        if self.range_noise is None:
            return lines
        lines += ["", "[corners]"]
        if seen is not None and seen.kind_scales:
            lines += [
                "# width of the fits' covariance against the scatter x (1 + rho)/(1 - rho), rho the correlation"
                " of a landmark's errors from scan to scan: "
                + "; ".join(
                    f"{kind} {seen.widths[kind]:.2f} x, rho {seen.correlations[kind]:.2f}" for kind in seen.kind_scales
                ),
                "covariance_scale = { "
                + ", ".join(f"{kind} = {scale:.3g}" for kind, scale in seen.kind_scales.items())
                + " }",
            ]
        lines += [
            "",
            "[corners.lines]",
            f"range_noise_std = {self.range_noise.std:.3g}   # m: the walls' scatter, "
            f"{self.range_noise.points} returns on {self.range_noise.lines} lines",
        ]
        return lines


@dataclass(frozen=True)
class _LogMeasurements:
    """What one log gives ``calibrate_logs`` before the fits: what it was measured against, the
    laser's range noise (None without scans), the motion's stretch errors (K, 4)
    (``motion_stretch_errors``) and what moved the filter, the observations' residuals."""

    reference: str
    range_noise: RangeNoise | None
    stretches: np.ndarray
    motion_source: str
    residuals: Residuals


def _measure_log(run: LoadedRun, config, progress: bool) -> _LogMeasurements:
    raw = dataclasses.replace(config.corners, covariance_scale={})  # measure the fits' own covariance
    extractor = CornerExtractor(run.geometry, run.log.width, raw) if run.log.n_beams else None
    range_noise = laser_range_noise(run.log.values[run.log.is_scan], extractor) if extractor is not None else None
    laser = laser_odometry(run.log, run.geometry, config.scan_matching) if config.scan_matching.enabled else None
    if run.truth is not None and len(run.true_corners):
        reference, poses, landmarks = "truth", run.truth, run.true_corners
    else:
        # The corner noises are measured against corner FastSLAM's landmarks, whatever [map] kind says.
        corner_fastslam = with_settings(config, {"map.kind": MapKind.LANDMARKS})
        result = run_slam(run, corner_fastslam, progress, laser=laser)
        reference, poses, landmarks = "the filter's path and map", result.mean_poses, result.landmarks
    stretches = motion_stretch_errors(
        run.log_without_glitches(config.odometry.jump_tolerance), run.truth if run.truth is not None else poses, laser
    )
    motion_source = (
        f"{'laser odometry' if laser is not None else 'odometry'} against "
        f"{'truth' if run.truth is not None else reference}"
    )
    residuals = observation_residuals(run, extractor, poses, landmarks, config.evaluation.match_radius)
    return _LogMeasurements(reference, range_noise, stretches, motion_source, residuals)


def calibrate(run: LoadedRun, config, progress: bool = False) -> Calibration:
    """Measure ``run``'s noises (see the module docstring) under the slam ``config``
    (``SlamConfig``: its corner settings, scan matching and, without truth, corner FastSLAM's
    ``[fastslam]`` settings: its path and landmarks are the reference, whatever ``[map] kind`` says)."""
    return calibrate_logs([run], config, progress)


def calibrate_logs(runs: Sequence[LoadedRun], config, progress: bool = False) -> Calibration:
    """One setting for a family of logs (one robot's or one dataset's): each log measured as
    ``calibrate`` does, and every fit made once over all their stretches, residuals and walls
    together, so that a log with more driving or more observations weighs more. A ValueError
    (a log without straight walls, logs that never drive) names the log, or the logs."""
    if not runs:
        raise ValueError("no log to calibrate")
    measured = []
    for run in runs:
        try:
            measured.append(_measure_log(run, config, progress))
        except ValueError as problem:
            raise ValueError(f"{run.path}: {problem}") from problem
    source = str(runs[0].path) if len(runs) == 1 else f"{len(runs)} logs ({', '.join(str(r.path) for r in runs)})"
    reference = "; ".join(sorted({m.reference for m in measured}))
    motion_source = "; ".join(sorted({m.motion_source for m in measured}))
    ranges = [m.range_noise for m in measured if m.range_noise is not None]
    range_noise = pooled_range_noise(ranges) if ranges else None
    try:
        motion = fit_noise(np.concatenate([m.stretches for m in measured]))
    except ValueError as problem:
        raise ValueError(f"{source}: {problem}") from problem
    residuals = pooled_residuals([m.residuals for m in measured])
    try:
        return Calibration(source, reference, range_noise, motion, motion_source, fit_observation_noise(residuals))
    except ValueError as problem:
        return Calibration(source, reference, range_noise, motion, motion_source, None, str(problem))
