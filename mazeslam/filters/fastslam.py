"""FastSLAM 1.0 (Montemerlo et al. 2002): a particle filter over robot paths, an EKF per landmark.

Each particle is one hypothesis of the robot pose and carries its own map: landmark means and 2x2
covariances (the Rao-Blackwellised factorisation in the exercise's overview). Everything is held
in arrays shaped by particles P and landmark slots M and updated with broadcasting; the only Python
loops run over the few observations of a scan.

State (all world frame, metres and radians):
    poses        (P, 3)        x, y, theta of every particle
    log_weights  (P,)          normalised so that logsumexp = 0
    means        (P, M, 2)     landmark positions
    covariances  (P, M, 2, 2)  landmark covariances
    exists       (P, M)        slot holds a landmark
    seen         (P, M)        times the landmark was observed
    missed       (P, M)        scans it was predicted in view but not observed (tentative ones only)
    ids          (P, M)        known identity of the landmark (-1: unknown)
    facings      (P, M)        world direction the landmark faces (rad; NaN: unknown)
    pose_covariances (P, 3, 3) FastSLAM 2.0 only: covariance of the motion since the last scan;
                               ``poses`` then holds the mean of that motion until a scan samples it

Observations are range and bearing ``z = (rho, phi)`` of a point landmark in the robot frame; the
measurement model is ``h(x, m) = (|m - x|, atan2(m_y - y, m_x - x) - theta)``.

The pieces are pure functions of their own modules: the EKF step (``ekf``), association
(``association``), resampling (``resampling``) and the two proposals, FastSLAM 1.0's and 2.0's
(``proposals``); this class holds the particles and runs them in order.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, field

import numpy as np

from mazeslam.config import require
from mazeslam.filters import ekf
from mazeslam.filters.association import associate_greedy, associate_known
from mazeslam.filters.motion import OdometryNoise
from mazeslam.filters.proposals import PROPOSALS
from mazeslam.filters.resampling import effective_sample_size, normalized_weights, systematic_resample
from mazeslam.geometry import wrap_angle

LOG_TWO_PI = math.log(2 * math.pi)


class Association(enum.StrEnum):
    """How observations are matched to landmarks."""

    UNKNOWN = "unknown"  #: maximum likelihood with a Mahalanobis gate
    KNOWN = "known"  #: identities given with the observations


@dataclass(frozen=True)
class FastSLAMParams:
    """Filter settings, named as in the exercise's control_panel.m where it has them.

    The noise defaults are measured, not tuned: the medians of ``mazeslam calibrate`` against the
    truth of ten simulated default mazes (experiments/calibration/summary.md). The odometry's
    match the simulator's wheel slip (0.003 m per sqrt(m) per wheel gives sigmaX 0.0021); the corner
    extractor's covariances, scaled per kind (``CornerParams.covariance_scale``), explain the
    residuals with no further range or bearing term (sigmaR = sigmaB = 0). ``inflation`` is the
    filter's own consistency margin on top of them.

    Attributes:
        NPARTICLES: number of particles.
        sigmaX: odometry distance noise, m per sqrt(m) travelled.
        sigmaTH: odometry heading noise from turning, rad per sqrt(rad) turned.
        sigmaTH_drive: odometry heading noise from driving, rad per sqrt(m) travelled.
        sigmaR, sigmaB: range (m) and bearing (rad) noise of an observation beyond the covariance
            the corner extractor reports (which already carries the laser's range noise): the
            whole noise of observations that come without one (landmark records).
        observation_scale: each observation's own covariance (from the corner extractor's line
            fits) enters the noise multiplied by this (0: not used; ``mazeslam calibrate``
            measures it).
        gate: Mahalanobis gate (squared) for associating an observation with a landmark
            (9.21: 99 % of a 2-D Gaussian).
        new_landmark_gate: an unassociated observation farther (squared Mahalanobis) than this
            from every landmark starts a new landmark; nearer ones are ambiguous and left out
            (counted in the diagnostics).
        resample_threshold: resample when the effective sample size falls below this fraction of
            NPARTICLES.
        association: "unknown" (maximum likelihood with the gate) or "known" (identities given).
        view_range: metres; a landmark this near is predicted to be observed.
        tentative_limit: a landmark seen only once is removed after this many scans in which it
            was predicted (within ``view_range``) but not observed.
        version: 1 samples each pose from the motion model (the exercise's FastSLAM 1.0); 2 samples
            it from the motion model combined with the scan's observations (FastSLAM 2.0,
            Montemerlo et al. 2003), which keeps more particles alive when the sensor is much more
            precise than the odometry.
        facing_gate: degrees; with unknown association, an observation is not associated with a
            landmark that faces more than this away from it (``CornerObservation.facing``): the two
            face corners of a wall end lie a wall's thickness apart but face opposite ways, the
            corners either side of a T-junction's stem 90 degrees apart, while one point seen as a
            corner or as a wall end faces 45 degrees apart. 180: off.
        inflation: the filter's consistency margin: every noise covariance it uses (motion and
            observation) is multiplied by this. The noise terms above are measured; a particle
            filter still underestimates its uncertainty (resampling narrows the paths' ancestry,
            Bailey et al. 2006; landmarks are linearised), so the margin is chosen for consistency
            - the smallest in (1, 1.25, 1.5, 2) whose pose NEES stays consistent over ten seeds
            (experiments/consistency) - never for the trajectory error.
        seed: seeds the filter's random draws.
    """

    NPARTICLES: int = 100
    sigmaX: float = 0.00203
    sigmaTH: float = 0.0120
    sigmaTH_drive: float = 0.0787
    sigmaR: float = 0.0
    sigmaB: float = 0.0
    observation_scale: float = 1.0
    gate: float = 9.21
    new_landmark_gate: float = 16.0
    resample_threshold: float = 0.5
    association: Association = Association.UNKNOWN
    view_range: float = 0.25
    tentative_limit: int = 3
    version: int = 2
    facing_gate: float = 67.5
    inflation: float = 2.0
    seed: int = 0

    def __post_init__(self):
        from mazeslam.limits import particles_problem

        require(self.NPARTICLES >= 1, f"NPARTICLES must be at least 1, got {self.NPARTICLES}")
        too_many = particles_problem(self.NPARTICLES)
        require(too_many is None, f"NPARTICLES: {too_many}")
        require(self.seed >= 0, f"seed must be a non-negative integer, got {self.seed}")
        for name in ("sigmaR", "sigmaB"):
            require(getattr(self, name) >= 0, f"{name} must be >= 0, got {getattr(self, name)}")
        OdometryNoise(self.sigmaX, self.sigmaTH, self.sigmaTH_drive)  # checks the odometry terms
        require(self.observation_scale >= 0, f"observation_scale must be >= 0, got {self.observation_scale}")
        require(
            self.sigmaR > 0 or self.observation_scale > 0,
            "sigmaR must be positive unless the observations' own covariances are used (observation_scale > 0)",
        )
        require(
            0 < self.gate <= self.new_landmark_gate,
            f"need 0 < gate <= new_landmark_gate, got {self.gate} and {self.new_landmark_gate}",
        )
        require(
            0 <= self.resample_threshold <= 1, f"resample_threshold must be in [0, 1], got {self.resample_threshold}"
        )
        require(
            self.association in tuple(Association),
            f"association must be one of {', '.join(Association)}, got {self.association!r}",
        )
        object.__setattr__(self, "association", Association(self.association))
        require(
            self.view_range >= 0 and 1 <= self.tentative_limit <= 1000,
            "view_range must be >= 0 and tentative_limit in 1..1000",
        )
        require(1 <= self.inflation < math.inf, f"inflation must be a factor >= 1, got {self.inflation}")
        require(0 < self.facing_gate <= 180, f"facing_gate must be in (0, 180] degrees, got {self.facing_gate}")
        require(self.version in PROPOSALS, f"version must be 1 or 2 (FastSLAM 1.0 or 2.0), got {self.version}")

    def observation_noise(self, covariances: np.ndarray | None, count: int) -> np.ndarray:
        """Observation noise R (K, 2, 2) of ``count`` observations as measured: diag(sigmaR^2,
        sigmaB^2) plus ``observation_scale`` times each one's own covariance (K, 2, 2) when given
        (the filter multiplies it by ``inflation``)."""
        fixed = np.diag([self.sigmaR**2, self.sigmaB**2])
        if covariances is None or self.observation_scale == 0:
            return np.broadcast_to(fixed, (count, 2, 2)).copy()
        return self.observation_scale * np.asarray(covariances, dtype=float).reshape(count, 2, 2) + fixed

    @property
    def odometry_noise(self) -> OdometryNoise:
        """The odometry terms sigmaX, sigmaTH, sigmaTH_drive as one noise model (as measured; the
        filter multiplies its variances by ``inflation``)."""
        return OdometryNoise(self.sigmaX, self.sigmaTH, self.sigmaTH_drive)


@dataclass
class UpdateReport:
    """What one scan's update did, summed over particles (diagnostics)."""

    observations: int = 0
    matched: int = 0
    new: int = 0
    ambiguous: int = 0
    removed: int = 0
    resampled: bool = False
    effective_sample_size: float = 0.0
    nis: np.ndarray = field(default_factory=lambda: np.empty(0))
    """(A,) normalised innovation squared of each associated observation (2 degrees of freedom):
    the squared Mahalanobis distance of its innovation under the predictive covariance the weights
    use, averaged over the particles that associated it with their weights before the scan."""


@dataclass
class MeasurementModel:
    """The measurement model of the first m landmark slots at the particles' current poses,
    against one scan's K observations (each entry of a 2x2 matrix is its own array, for speed).

    Attributes:
        rho, bearing: (P, m) predicted range (m) and bearing (rad) of every slot.
        h: the landmark Jacobian d(rho, bearing)/d(landmark) as entries (a, b, c, d), each (P, m).
        nu: the innovations (range, bearing) of every observation-slot pair, each (P, K, m).
        det, distance2: determinant and squared Mahalanobis distance of the innovation under
            S = H Sigma H^T + R (+ Gx Sigma_x Gx^T with the pose's uncertainty), each (P, K, m);
            distance2 is inf for empty slots.
    """

    rho: np.ndarray
    bearing: np.ndarray
    h: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]
    nu: tuple[np.ndarray, np.ndarray]
    det: np.ndarray
    distance2: np.ndarray

    def jacobians(self, rows: np.ndarray, slots: np.ndarray) -> np.ndarray:
        """H (n, 2, 2) of the particle-slot pairs ``rows``, ``slots`` (n,) each."""
        a, b, c, d = (entry[rows, slots] for entry in self.h)
        return np.stack([np.stack([a, b], -1), np.stack([c, d], -1)], -2)


class FastSLAM:
    """The filter. ``predict`` with each odometry record, ``update`` with each scan's observations.

    The proposal (``params.version``: 1 ``MotionProposal``, 2 ``ObservationProposal``) decides when
    a pose's noise is drawn; everything else is shared.
    """

    def __init__(self, params: FastSLAMParams, start_pose=(0.0, 0.0, 0.0), capacity: int = 32):
        self.params = params
        self.proposal = PROPOSALS[params.version]()
        self.motion_noise = params.odometry_noise.inflated(params.inflation)
        self.rng = np.random.default_rng(params.seed)
        p = params.NPARTICLES
        self.poses = np.tile(np.asarray(start_pose, dtype=float), (p, 1))
        self.log_weights = np.full(p, -math.log(p))
        self.means = np.zeros((p, capacity, 2))
        self.covariances = np.tile(np.eye(2), (p, capacity, 1, 1))
        self.exists = np.zeros((p, capacity), dtype=bool)
        self.seen = np.zeros((p, capacity), dtype=np.int32)
        self.missed = np.zeros((p, capacity), dtype=np.int32)
        self.ids = np.full((p, capacity), -1, dtype=np.int64)
        self.facings = np.full((p, capacity), np.nan)
        self.pose_covariances = np.zeros((p, 3, 3))
        self.resamplings = 0

    # -- motion -----------------------------------------------------------------------------
    def predict(self, distance: float, turn: float) -> None:
        """Move every particle by an odometry increment (metres, radians).

        FastSLAM 1.0 draws each particle's noise now. FastSLAM 2.0 moves the particles' means
        without noise and accumulates the motion's covariance, to be combined with the next scan's
        observations (``update``) before a pose is drawn.
        """
        self.poses, self.pose_covariances = self.proposal.predict(
            self.poses, self.pose_covariances, distance, turn, self.motion_noise, self.rng
        )

    def predict_relative(self, increment) -> None:
        """Move every particle by a relative motion ``increment`` (dx, dy, dtheta) given in its own
        robot frame (laser odometry), with the noise of ``OdometryNoise.relative_covariance``; the
        proposal decides when the noise is drawn, as in ``predict``."""
        increment = np.asarray(increment, dtype=float)
        covariance = self.motion_noise.relative_covariance(increment)
        self.poses, self.pose_covariances = self.proposal.predict_relative(
            self.poses, self.pose_covariances, increment, covariance, self.rng
        )

    # -- observation model --------------------------------------------------------------------
    def _used_slots(self) -> int:
        """Slots 0..m-1 hold every landmark of every particle; the rest is spare capacity."""
        used = np.flatnonzero(self.exists.any(axis=0))
        return int(used[-1]) + 1 if len(used) else 0

    def _predicted(self, m: int):
        """For the first ``m`` slots: predicted range and bearing (P, m) each, and the Jacobian
        H = d(range, bearing)/d(landmark) as its four entries (P, m) each: [[a, b], [c, d]]."""
        delta = self.means[:, :m] - self.poses[:, None, :2]
        dx, dy = delta[..., 0], delta[..., 1]
        q = np.maximum(dx * dx + dy * dy, 1e-12)
        rho = np.sqrt(q)
        bearing = wrap_angle(np.arctan2(dy, dx) - self.poses[:, None, 2])
        return rho, bearing, (dx / rho, dy / rho, -dy / q, dx / q)

    # -- update -------------------------------------------------------------------------------
    def update(
        self,
        observations: np.ndarray,
        covariances: np.ndarray | None = None,
        ids: np.ndarray | None = None,
        facings: np.ndarray | None = None,
    ) -> UpdateReport:
        """Weigh and correct every particle with one scan's observations.

        Args:
            observations: (K, 2) range (m) and bearing (rad) in the robot frame.
            covariances: (K, 2, 2) their covariances, or None.
            ids: (K,) known landmark identities (``association="known"``; -1: none, the observation
                is left out and counted as ambiguous), else None.
            facings: (K,) the directions the observed landmarks face (rad, robot frame), or None.
        Steps: 1. associate (with the pose's uncertainty for FastSLAM 2.0); 2. draw the poses
        (FastSLAM 2.0); 3. update matched landmarks, start new ones and weigh the particles;
        4. drop tentative landmarks that were missed; 5. resample when the weights degenerate.
        """
        observations = np.asarray(observations, dtype=float).reshape(-1, 2)
        report = UpdateReport(observations=len(observations))
        count = len(observations)
        known = self.params.association == Association.KNOWN
        if count and known and ids is None:
            raise ValueError("association='known' needs the observations' ids")
        while count and (~self.exists).sum(axis=1).min() < count:  # room for every observation to start a landmark
            self._grow()
        noise = self.params.inflation * self.params.observation_noise(covariances, count)
        m = self._used_slots()
        # 1. Association, under the model the weights use.
        prior = self._model(observations, noise, m, self.proposal.carries_pose_uncertainty)
        relative_facings = None if facings is None else np.asarray(facings, dtype=float)
        if known and count:
            assigned = associate_known(np.asarray(ids), self.ids[:, :m], self.exists[:, :m])
        else:
            if relative_facings is not None and m and self.params.facing_gate < 180:
                self._gate_by_facing(prior.distance2, relative_facings, m)
            assigned = associate_greedy(prior.distance2, self.params.gate)
        # 2. The proposal's draw; the landmarks are then corrected at the drawn poses.
        model = prior
        self.poses, self.pose_covariances, joint = self.proposal.draw(
            self.poses, self.pose_covariances, assigned, observations, self.means, self.covariances, noise, self.rng
        )
        if self.proposal.carries_pose_uncertainty:
            model = self._model(observations, noise, m, with_pose_uncertainty=False)
        # 3. Landmarks and weights, observation by observation.
        likelihood = joint if joint is not None else _associated_terms(prior, assigned)
        report.nis = _normalised_innovations(likelihood[0], assigned, self.weights())
        matched_now = np.zeros_like(self.exists)
        for k in range(count):
            self._apply(
                k,
                assigned[:, k],
                model,
                prior.distance2,
                likelihood,
                observations[k],
                noise[k],
                None if ids is None else ids[k],
                None if relative_facings is None else relative_facings[k],
                matched_now,
                report,
            )
        # 4. Tentative landmarks predicted in view but not seen.
        if count:
            self._manage_landmarks(model.rho, matched_now, report)
        # 5. Selective resampling.
        report.effective_sample_size = self.effective_sample_size()
        if report.effective_sample_size < self.params.resample_threshold * self.params.NPARTICLES:
            self.resample()
            report.resampled = True
        return report

    def _model(
        self, observations: np.ndarray, noise: np.ndarray, m: int, with_pose_uncertainty: bool
    ) -> MeasurementModel:
        """The measurement model of the first ``m`` slots at the current poses (see
        ``MeasurementModel``); ``with_pose_uncertainty`` adds the motion covariance not yet drawn."""
        rho, bearing, h = self._predicted(m)
        a, b, c, d = h
        sigma = self.covariances[:, :m]
        s00, s01, s11 = sigma[..., 0, 0], sigma[..., 0, 1], sigma[..., 1, 1]
        t00 = a * a * s00 + 2 * a * b * s01 + b * b * s11
        t01 = a * c * s00 + (a * d + b * c) * s01 + b * d * s11
        t11 = c * c * s00 + 2 * c * d * s01 + d * d * s11
        if with_pose_uncertainty:
            gx = np.stack([np.stack([-a, -b, np.zeros_like(a)], -1), np.stack([-c, -d, -np.ones_like(a)], -1)], -2)
            pose_term = gx @ self.pose_covariances[:, None] @ np.swapaxes(gx, -1, -2)  # (P, m, 2, 2)
            t00, t01, t11 = t00 + pose_term[..., 0, 0], t01 + pose_term[..., 0, 1], t11 + pose_term[..., 1, 1]
        t00 = t00[:, None] + noise[None, :, 0, 0, None]
        t01 = t01[:, None] + noise[None, :, 0, 1, None]
        t11 = t11[:, None] + noise[None, :, 1, 1, None]
        det = t00 * t11 - t01 * t01
        nu0 = observations[None, :, 0, None] - rho[:, None]
        nu1 = wrap_angle(observations[None, :, 1, None] - bearing[:, None])
        distance2 = (t11 * nu0 * nu0 - 2 * t01 * nu0 * nu1 + t00 * nu1 * nu1) / det
        distance2[~np.broadcast_to(self.exists[:, None, :m], distance2.shape)] = np.inf
        return MeasurementModel(rho, bearing, h, (nu0, nu1), det, distance2)

    def _apply(
        self,
        k,
        slots,
        model: MeasurementModel,
        distance2: np.ndarray,
        likelihood,
        observation,
        noise,
        identity,
        facing,
        matched_now,
        report,
    ) -> None:
        """EKF-update the landmarks matched by observation k, start new ones, and weigh the particles.

        ``model`` linearises at the poses the particles now have; ``distance2`` (P, K, m) is the
        association's, which decides whether an unmatched observation is new; ``likelihood`` the
        squared Mahalanobis distances and determinants (P, K) of the associated observations that
        weigh the particles (the association's for FastSLAM 1.0; the joint scan likelihood's
        factors for 2.0). ``identity`` and ``facing`` are the observation's (None: unknown).
        """
        rows = np.flatnonzero(slots >= 0)
        if len(rows):
            j = slots[rows]
            residual = np.column_stack([model.nu[0][rows, k, j], model.nu[1][rows, k, j]])
            self.means[rows, j], self.covariances[rows, j], _ = ekf.update(
                self.means[rows, j], self.covariances[rows, j], residual, model.jacobians(rows, j), noise
            )
            self.log_weights[rows] += -0.5 * likelihood[0][rows, k] - LOG_TWO_PI - 0.5 * np.log(likelihood[1][rows, k])
            self.seen[rows, j] += 1
            self.missed[rows, j] = 0
            matched_now[rows, j] = True
            report.matched += len(rows)
        unmatched = slots < 0
        nearest = distance2[:, k].min(axis=1, initial=np.inf)
        # Known association: an identity not yet mapped starts a landmark; none (-1): left out.
        if self.params.association == Association.KNOWN:
            new = unmatched & (identity >= 0)
        else:
            new = unmatched & (nearest >= self.params.new_landmark_gate)
        report.ambiguous += int((unmatched & ~new).sum())
        if new.any():
            self._add_landmarks(np.flatnonzero(new), observation, noise, identity, facing, matched_now)
            # A new landmark's likelihood: the density at the edge of the new-landmark gate.
            self.log_weights[new] += (
                -0.5 * self.params.new_landmark_gate - LOG_TWO_PI - 0.5 * math.log(np.linalg.det(noise))
            )
            report.new += int(new.sum())

    def _add_landmarks(self, rows: np.ndarray, observation, noise, identity, facing, matched_now) -> None:
        """Initialise a landmark from one observation in each particle of ``rows`` (its identity
        and its facing relative to the robot, rad, or None)."""
        slots = (~self.exists[rows]).argmax(axis=1)  # the first free slot (update made room)
        rho, bearing = observation
        angle = self.poses[rows, 2] + bearing
        cos_a, sin_a = np.cos(angle), np.sin(angle)
        self.means[rows, slots] = self.poses[rows, :2] + rho * np.column_stack([cos_a, sin_a])
        # Inverse measurement Jacobian dm/d(rho, bearing), then Sigma = G R G^T.
        g = np.stack([np.stack([cos_a, -rho * sin_a], -1), np.stack([sin_a, rho * cos_a], -1)], -2)
        self.covariances[rows, slots] = g @ noise @ np.swapaxes(g, -1, -2)
        self.exists[rows, slots] = True
        self.seen[rows, slots] = 1
        self.missed[rows, slots] = 0
        self.ids[rows, slots] = -1 if identity is None else identity
        self.facings[rows, slots] = np.nan if facing is None else wrap_angle(self.poses[rows, 2] + facing)
        matched_now[rows, slots] = True

    def _grow(self) -> None:
        """Double the landmark slots of every particle."""
        p, m = self.exists.shape
        self.means = np.concatenate([self.means, np.zeros((p, m, 2))], axis=1)
        self.covariances = np.concatenate([self.covariances, np.tile(np.eye(2), (p, m, 1, 1))], axis=1)
        self.exists = np.concatenate([self.exists, np.zeros((p, m), dtype=bool)], axis=1)
        self.seen = np.concatenate([self.seen, np.zeros((p, m), dtype=np.int32)], axis=1)
        self.missed = np.concatenate([self.missed, np.zeros((p, m), dtype=np.int32)], axis=1)
        self.ids = np.concatenate([self.ids, np.full((p, m), -1, dtype=np.int64)], axis=1)
        self.facings = np.concatenate([self.facings, np.full((p, m), np.nan)], axis=1)

    def _gate_by_facing(self, distance2: np.ndarray, facings: np.ndarray, m: int) -> None:
        """Rule out (inf in ``distance2`` (P, K, m)) every pair whose landmark faces more than
        ``facing_gate`` away from the observation (``facings`` (K,) relative to the robot, rad);
        landmarks or observations of unknown facing (NaN) are not ruled out."""
        world = self.poses[:, None, 2] + facings[None, :]  # (P, K)
        apart = np.abs(wrap_angle(world[:, :, None] - self.facings[:, None, :m]))
        distance2[apart > math.radians(self.params.facing_gate)] = np.inf  # NaN compares False: kept

    def _manage_landmarks(self, predicted_range: np.ndarray, matched_now: np.ndarray, report: UpdateReport) -> None:
        """Count misses of tentative landmarks predicted in view (``predicted_range`` (P, m) of the
        slots that existed before this scan), and remove repeatedly missed ones."""
        m = predicted_range.shape[1]
        in_view = (
            self.exists[:, :m]
            & (self.seen[:, :m] <= 1)
            & ~matched_now[:, :m]
            & (predicted_range < self.params.view_range)
        )
        self.missed[:, :m][in_view] += 1
        remove = self.exists & (self.missed >= self.params.tentative_limit)
        report.removed += int(remove.sum())
        self.exists[remove] = False

    # -- weights ------------------------------------------------------------------------------
    def weights(self) -> np.ndarray:
        """Normalised particle weights (P,)."""
        return normalized_weights(self.log_weights)

    def effective_sample_size(self) -> float:
        return effective_sample_size(self.weights())

    def resample(self) -> None:
        """Low-variance (systematic) resampling; weights become uniform."""
        index = systematic_resample(self.weights(), self.rng)
        for name in ("poses", "means", "covariances", "exists", "seen", "missed", "ids", "facings", "pose_covariances"):
            setattr(self, name, getattr(self, name)[index])
        self.log_weights = np.full(len(index), -math.log(len(index)))
        self.resamplings += 1

    # -- estimates ----------------------------------------------------------------------------
    def mean_pose(self) -> np.ndarray:
        """Weighted mean pose (3,); the heading is the circular mean."""
        w = self.weights()
        x, y = w @ self.poses[:, 0], w @ self.poses[:, 1]
        theta = math.atan2(w @ np.sin(self.poses[:, 2]), w @ np.cos(self.poses[:, 2]))
        return np.array([x, y, theta])

    def pose_covariance(self) -> np.ndarray:
        """Covariance (3, 3) of the weighted particle cloud around ``mean_pose`` (heading
        differences wrapped); FastSLAM 2.0 adds the motion uncertainty not yet drawn."""
        w = self.weights()
        deviation = self.poses - self.mean_pose()
        deviation[:, 2] = wrap_angle(deviation[:, 2])
        covariance = np.einsum("p,pi,pj->ij", w, deviation, deviation)
        return covariance + np.einsum("p,pij->ij", w, self.pose_covariances)

    def best_particle(self) -> int:
        return int(np.argmax(self.log_weights))

    def landmarks(self, particle: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Landmark means (L, 2) and covariances (L, 2, 2) of one particle (default: the best)."""
        particle = self.best_particle() if particle is None else particle
        keep = self.exists[particle]
        return self.means[particle, keep], self.covariances[particle, keep]


def _associated_terms(model: MeasurementModel, assigned: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The squared Mahalanobis distance and determinant (P, K) of each observation's innovation
    with the slot ``assigned`` (P, K) to it (NaN where none)."""
    rows, observations = np.nonzero(assigned >= 0)
    distance2, determinant = np.full(assigned.shape, np.nan), np.full(assigned.shape, np.nan)
    slots = assigned[rows, observations]
    distance2[rows, observations] = model.distance2[rows, observations, slots]
    determinant[rows, observations] = model.det[rows, observations, slots]
    return distance2, determinant


def _normalised_innovations(distance2: np.ndarray, assigned: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """NIS (A,) of the observations that most of the weight associates: for observation k, the
    weight-averaged squared Mahalanobis distance ``distance2`` (P, K) over the particles whose
    ``assigned`` (P, K) slot is not -1, with their normalised ``weights`` (P,) before the scan."""
    values = []
    for k in range(assigned.shape[1]):
        rows = np.flatnonzero(assigned[:, k] >= 0)
        if weights[rows].sum() > 0.5:
            values.append(np.average(distance2[rows, k], weights=weights[rows]))
    return np.asarray(values, dtype=float)
