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

from mazeslam.core import resampling
from mazeslam.core.config import require
from mazeslam.core.geometry import wrap_angle
from mazeslam.core.motion import OdometryNoise
from mazeslam.core.resampling import effective_sample_size, normalized_weights
from mazeslam.fastslam import ekf
from mazeslam.fastslam.association import associate_greedy, associate_known
from mazeslam.fastslam.proposals import PROPOSALS

LOG_TWO_PI = math.log(2 * math.pi)
#: The spatial index's reach is widened by this factor against rounding (``FastSLAM._reach``).
CULL_SAFETY = 1.01
#: Metres: after resampling, the index boxes of slots wider than this (a slot that held landmarks
#: far apart in different particles) are rebuilt from the particles drawn (``FastSLAM.reindex``).
REINDEX_WIDTH = 0.1


class Association(enum.StrEnum):
    """How observations are matched to landmarks."""

    UNKNOWN = "unknown"  #: maximum likelihood with a Mahalanobis gate
    KNOWN = "known"  #: identities given with the observations


class FilterDivergence(ValueError):
    """The filter's numbers went bad: an observation noise, innovation or landmark covariance that
    is not positive definite, a pose or a particle weight that is not finite. Raised where it first
    happens, before numpy divides by it, with what went bad and the settings to check (the noise
    settings and association, which a log they do not fit breaks first); ``run_fastslam`` adds the
    log's line. A ``ValueError``: the command line prints it as one line.

    Attributes:
        what: what went bad, in words.
    """

    def __init__(self, what: str, params: FastSLAMParams | None = None, where: str | None = None):
        self.what, self.params, self.where = what, params, where
        hint = f"; {settings_hint(params)}" if params is not None else ""
        super().__init__(f"{where + ': ' if where else ''}FastSLAM diverged: {what}{hint}")

    def at(self, where: str) -> FilterDivergence:
        """This divergence located at ``where`` (the log and its line, for the message)."""
        return FilterDivergence(self.what, self.params, where)


def settings_hint(params: FastSLAMParams) -> str:
    """The settings a log that does not fit them breaks first, with their values: one clause for
    ``FilterDivergence`` and the pipeline's checks."""
    return (
        f"check [fastslam]'s observation noise (sigmaR = {params.sigmaR:g}, sigmaB = {params.sigmaB:g}, "
        f"observation_scale = {params.observation_scale:g}), odometry noise (sigmaX = {params.sigmaX:g}, "
        f"sigmaTH = {params.sigmaTH:g}, sigmaTH_drive = {params.sigmaTH_drive:g}; `mazeslam calibrate` measures "
        f"both) and association ({params.association.value!r}) against this log; a log imported from MRCLAM "
        "wants --config configs/mrclam.toml"
    )


@dataclass(frozen=True)
class FastSLAMParams:
    """Filter settings, named as in the exercise's control_panel.m where it has them.

    The noise defaults are measured, not tuned: ``mazeslam calibrate`` against the truth of ten
    simulated default mazes (experiments/calibration/summary.md). The odometry's are the largest
    of the ten seeds' measurements, so that the motion model is at least as wide as every seed's
    odometry (the simulator's wheel slip, 0.003 m per sqrt(m) per wheel, gives sigmaX 0.0021); the
    corner extractor's covariances, scaled per kind (``CornerParams.covariance_scale``, the
    medians), explain the observations' residuals with no further range or bearing term
    (sigmaR = sigmaB = 0). The models are used as measured, so that NIS checks them; the filter's
    own consistency margin is ``likelihood_exponent``, on the particle weights only.

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
        likelihood_exponent: each scan's likelihood enters the particle weights raised to this
            power (0 < exponent <= 1; 1: the plain product). The filter's consistency margin: a
            particle filter loses the diversity of its particles' paths and maps at every
            resampling (Bailey, Nieto and Nebot, "Consistency of the FastSLAM algorithm", ICRA
            2006), after which the cloud no longer covers the error of the map as a whole; flatter
            weights resample less often and keep it longer (gmapping's likelihood gain does the
            same). Chosen for NEES, never for the trajectory error: the largest of 1, 0.5, 0.35,
            0.25, 0.15, 0.1 whose worst seed's median pose NEES stays under 10 at 100 particles
            (seeds 11-30; half the bar of 20 the filter is held to there) and under the 95 % point
            7.81 at 1000 particles (seeds 11-20) (experiments/consistency/margin.md).
        inflation: a factor on every noise covariance the filter uses (motion and observation),
            for studies of the noise settings; 1: the noise as measured.
        seed: seeds the filter's random draws.
    """

    NPARTICLES: int = 100
    sigmaX: float = 0.00223
    sigmaTH: float = 0.0150
    sigmaTH_drive: float = 0.0865
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
    likelihood_exponent: float = 0.15
    inflation: float = 1.0
    seed: int = 0

    def __post_init__(self):
        from mazeslam.core.limits import particles_problem

        require(self.NPARTICLES >= 1, f"NPARTICLES must be at least 1, got {self.NPARTICLES}")
        too_many = particles_problem(self.NPARTICLES)
        require(too_many is None, f"NPARTICLES: {too_many}")
        require(self.seed >= 0, f"seed must be a non-negative integer, got {self.seed}")
        for name in ("sigmaR", "sigmaB"):
            value = getattr(self, name)
            require(0 <= value < math.inf, f"{name} must be >= 0 and finite, got {value}")
        OdometryNoise(self.sigmaX, self.sigmaTH, self.sigmaTH_drive)  # checks the odometry terms
        require(
            0 <= self.observation_scale < math.inf,
            f"observation_scale must be >= 0 and finite, got {self.observation_scale}",
        )
        require(
            (self.sigmaR > 0 and self.sigmaB > 0) or self.observation_scale > 0,
            "sigmaR and sigmaB must be positive unless the observations' own covariances are used "
            f"(observation_scale > 0), got {self.sigmaR} and {self.sigmaB}",
        )
        require(
            0 < self.gate <= self.new_landmark_gate < math.inf,
            f"need 0 < gate <= new_landmark_gate (finite), got {self.gate} and {self.new_landmark_gate}",
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
        require(
            0 < self.likelihood_exponent <= 1,
            f"likelihood_exponent must be in (0, 1], got {self.likelihood_exponent}",
        )
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
    nis_observations: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=np.int64))
    """(A,) the index in the scan's observations of each ``nis`` value."""
    pairs: int = 0
    """Observation-slot pairs the spatial index kept (``Candidates.near``)."""
    within_reach: int = 0
    """Their particle-observation-slot triples within reach (``FastSLAM._modelled``)."""
    modelled: int = 0
    """The triples the measurement model computed (those the facing gate left)."""


@dataclass
class Candidates:
    """The landmark slots that can matter to one scan: those near its observations, found before
    any Mahalanobis work (``FastSLAM._candidates``), so the cost per observation does not grow
    with the map.

    Attributes:
        slots: (C,) the slots, ascending (the same for every particle).
        valid: (P, C) the particle holds a landmark in that slot.
        near: (K, C) the observation-slot pairs that can matter; the others are beyond the
            new-landmark gate in every particle.
        points: (2, K, P) where each particle puts each observation (x and y, metres, world
            frame), or None: then every particle holding the slot of a ``near`` pair is modelled.
        reach2: (K, C) squared metres, with ``points``: a particle whose landmark of the pair lies
            this far or farther from where it puts the observation has the pair beyond the
            new-landmark gate (``FastSLAM._reach``); 0 outside ``near``.
        forced: (P, K) the candidate column modelled for each particle and observation whatever
            its distance (known association's slots; -1: none), or None.
    """

    slots: np.ndarray
    valid: np.ndarray
    near: np.ndarray
    points: np.ndarray | None = None
    reach2: np.ndarray | None = None
    forced: np.ndarray | None = None

    def slots_of(self, columns: np.ndarray) -> np.ndarray:
        """Slots (P, K) of candidate ``columns`` (P, K) (-1 stays -1)."""
        if not len(self.slots):
            return np.full(columns.shape, -1)
        return np.where(columns >= 0, self.slots[np.maximum(columns, 0)], -1)

    def columns_of(self, slots: np.ndarray) -> np.ndarray:
        """Candidate columns (P, K) of ``slots`` (P, K), which must be candidates (-1 stays -1)."""
        return np.where(slots >= 0, np.searchsorted(self.slots, slots), -1)


@dataclass
class MeasurementModel:
    """The measurement model of the candidate landmarks at the particles' current poses, against
    one scan's K observations.

    Attributes:
        candidates: the landmark slots modelled, C of them: those of ``FastSLAM._candidates``
            with a triple computed (without ``points``, ``reach2`` and ``forced``).
        distance2: (P, K, C) squared Mahalanobis distance of the innovation under
            S = H Sigma H^T + R (+ Gx Sigma_x Gx^T with the pose's uncertainty), computed for the
            particle-observation-slot triples ``FastSLAM._modelled`` keeps only: elsewhere inf
            (slots the particle does not hold, pairs beyond the new-landmark gate in that
            particle, and pairs the facing gate rules out).
        triples: (E,) the flat indexes into ``distance2`` of the triples computed.
        triple_det: (E,) the determinant of S of each (``det`` spreads it over (P, K, C)).
        pairs: how many observation-slot pairs the index kept; within_reach: how many triples
            ``FastSLAM._modelled`` kept of them (before the facing gate).
    """

    candidates: Candidates
    distance2: np.ndarray
    triples: np.ndarray
    triple_det: np.ndarray
    pairs: int = 0
    within_reach: int = 0

    @property
    def det(self) -> np.ndarray:
        """(P, K, C) the determinant of S, NaN outside the triples (made when asked for: only
        FastSLAM 1.0's weights use it)."""
        det = np.full(self.distance2.shape, np.nan)
        det.reshape(-1)[self.triples] = self.triple_det
        return det


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
        self.reindex()

    # -- motion -----------------------------------------------------------------------------
    def predict(self, distance: float, turn: float) -> None:
        """Move every particle by an odometry increment (metres, radians).

        FastSLAM 1.0 draws each particle's noise now. FastSLAM 2.0 moves the particles' means
        without noise and accumulates the motion's covariance, to be combined with the next scan's
        observations (``update``) before a pose is drawn.
        """
        if not (math.isfinite(distance) and math.isfinite(turn)):
            raise ValueError(f"an odometry increment must be finite, got {distance} m and {turn} rad")
        self.poses, self.pose_covariances = self.proposal.predict(
            self.poses, self.pose_covariances, distance, turn, self.motion_noise, self.rng
        )

    def predict_relative(self, increment) -> None:
        """Move every particle by a relative motion ``increment`` (dx, dy, dtheta) given in its own
        robot frame (laser odometry), with the noise of ``OdometryNoise.relative_covariance``; the
        proposal decides when the noise is drawn, as in ``predict``."""
        increment = np.asarray(increment, dtype=float)
        if not np.isfinite(increment).all():
            raise ValueError(f"a relative motion must be finite, got {increment.tolist()}")
        covariance = self.motion_noise.relative_covariance(increment)
        self.poses, self.pose_covariances = self.proposal.predict_relative(
            self.poses, self.pose_covariances, increment, covariance, self.rng
        )

    # -- observation model --------------------------------------------------------------------
    def _used_slots(self) -> int:
        """Slots 0..m-1 hold every landmark of every particle; the rest is spare capacity. (Read
        from the index: a slot whose box is not empty holds, or held, a landmark.)"""
        used = np.flatnonzero(self._boxes[:, 0] <= self._boxes[:, 2])
        return int(used[-1]) + 1 if len(used) else 0

    def _gaps(self, low: np.ndarray, high: np.ndarray, m: int) -> np.ndarray:
        """(m, B) squared distance (m^2) between the index box of each of the first ``m`` slots and
        each of B boxes with corners ``low`` and ``high`` (B, 2) (world frame); inf for a slot
        that holds no landmark."""
        box = self._boxes[:m, :, None]  # (m, 4, 1): x min, y min, x max, y max
        gap_x = np.maximum(np.maximum(box[:, 0] - high[:, 0], low[:, 0] - box[:, 2]), 0.0)
        gap_y = np.maximum(np.maximum(box[:, 1] - high[:, 1], low[:, 1] - box[:, 3]), 0.0)
        return gap_x * gap_x + gap_y * gap_y

    def _candidates(self, observations: np.ndarray, noise: np.ndarray, m: int, assigned=None) -> Candidates:
        """The slots among the first ``m`` that can be associated with any of the scan's
        ``observations`` (K, 2) of noise ``noise`` (K, 2, 2), plus the ``assigned`` (P, K) slots of
        known association.

        A spatial index over slots: every slot's landmarks, in whichever particles hold one, lie in
        its box (``reindex``); every particle's k-th observation lies, in the world frame, in the
        box of that observation over the particles. A slot whose box is at least ``_reach``
        metres from every observation's box is left out: it could neither be associated nor make
        an observation ambiguous in any particle. The cost is a few operations per slot and
        observation; the C slots near the observations (C stays flat as the map grows) then go to
        ``_modelled``, which checks the same reach per particle, with the points where each
        particle puts each observation and the squared reach of each pair.
        """
        p = len(self.poses)
        if m == 0 or not len(observations):
            return Candidates(
                np.zeros(0, dtype=np.int64), np.zeros((p, 0), dtype=bool), np.zeros((len(observations), 0), dtype=bool)
            )
        angle = self.poses[None, :, 2] + observations[:, None, 1]  # (K, P)
        x = self.poses[None, :, 0] + observations[:, None, 0] * np.cos(angle)
        y = self.poses[None, :, 1] + observations[:, None, 0] * np.sin(angle)
        low = np.column_stack([x.min(axis=1), y.min(axis=1)])  # (K, 2): each observation's box
        high = np.column_stack([x.max(axis=1), y.max(axis=1)])
        reach2 = self._reach(observations, noise, m) ** 2  # (m, K)
        near = self._gaps(low, high, m) < reach2
        if assigned is not None:
            rows, ks = np.nonzero(assigned >= 0)
            near[assigned[rows, ks], ks] = True
        columns = np.flatnonzero(near.any(axis=1))
        near = near[columns].T
        candidates = Candidates(
            columns, self.exists[:, columns], near, np.stack([x, y]), np.where(near, reach2[columns].T, 0.0)
        )
        if assigned is not None:
            candidates.forced = candidates.columns_of(assigned)
        return candidates

    def _reach(self, observations: np.ndarray, noise: np.ndarray, m: int) -> np.ndarray:
        """(m, K) metres: a landmark of slot j farther than this from where observation k puts it
        is beyond the new-landmark gate G (squared Mahalanobis) in every particle.

        With innovation nu = (r - rho, bearing difference) of a landmark at range rho and an
        observation at range r, |landmark - observed point|^2 <= nu_0^2 + r rho nu_1^2, and
        nu^T S^-1 nu < G implies nu_i^2 < G S_ii. S_00 <= lam + R_00 and
        S_11 <= lam / rho^2 + 2 c / rho + v + R_11, lam bounding the eigenvalues of the landmark's
        plus the pose's position covariance, c the pose's position-heading covariance, v its
        heading variance (FastSLAM 2.0). Where rho may be near 0 the plain bound r + rho is used.
        """
        gate = self.params.new_landmark_gate
        pose = self.pose_covariances
        lam = self._spreads[:m, None] + (pose[:, 0, 0] + pose[:, 1, 1]).max()  # (m, 1)
        cross, heading = np.hypot(pose[:, 0, 2], pose[:, 1, 2]).max(), pose[:, 2, 2].max()
        r, r00, r11 = observations[:, 0], noise[:, 0, 0], noise[:, 1, 1]  # (K,)
        delta = np.sqrt(gate * (lam + r00))  # |nu_0| bound, (m, K)
        farthest = r + delta  # rho bound
        plain = r + farthest
        ratio = r / np.maximum(r - delta, 1e-12)  # r / rho bound where r - delta > 0
        bound = np.sqrt(gate * (lam * (1 + ratio) + r00 + 2 * r * cross + r * farthest * (heading + r11)))
        return CULL_SAFETY * np.where(r >= 2 * delta, np.minimum(bound, plain), plain)

    def reindex(self, slots: np.ndarray | slice = slice(None)) -> None:
        """Rebuild the slots' spatial index from the landmark arrays (all slots, or ``slots``):
        each slot's box (x min, y min, x max, y max, metres) around its landmarks in every
        particle, and the largest trace of their covariances (m^2). The filter keeps it up to date
        (updates widen it, resampling rebuilds the boxes a reused slot made wide); call this after
        writing ``means``, ``covariances`` or ``exists`` directly."""
        if isinstance(slots, slice):
            self._boxes = np.empty((self.exists.shape[1], 4))
            self._spreads = np.empty(self.exists.shape[1])
        exists, means, covariances = self.exists[:, slots], self.means[:, slots], self.covariances[:, slots]
        x, y = means[..., 0], means[..., 1]
        self._boxes[slots, 0] = np.where(exists, x, np.inf).min(axis=0)
        self._boxes[slots, 1] = np.where(exists, y, np.inf).min(axis=0)
        self._boxes[slots, 2] = np.where(exists, x, -np.inf).max(axis=0)
        self._boxes[slots, 3] = np.where(exists, y, -np.inf).max(axis=0)
        self._spreads[slots] = np.where(exists, covariances[..., 0, 0] + covariances[..., 1, 1], 0.0).max(axis=0)

    def _widen_index(self, rows: np.ndarray, slots: np.ndarray, means=None, covariances=None) -> None:
        """Widen the index (``reindex``) to the landmarks ``rows``, ``slots`` (n,) just written
        (only those outside their slot's box or above its spread: a landmark update shrinks the
        covariance and moves the mean a little); ``means`` (n, 2) and ``covariances`` (n, 2, 2):
        what was written there, when at hand."""
        means = self.means[rows, slots] if means is None else means
        covariances = self.covariances[rows, slots] if covariances is None else covariances
        spread = covariances[:, 0, 0] + covariances[:, 1, 1]
        box = self._boxes[slots]
        out = (
            (means[:, 0] < box[:, 0])
            | (means[:, 1] < box[:, 1])
            | (means[:, 0] > box[:, 2])
            | (means[:, 1] > box[:, 3])
            | (spread > self._spreads[slots])
        )
        slots, means, spread = slots[out], means[out], spread[out]
        for column, reduce, values in (
            (0, np.minimum, means[:, 0]),
            (1, np.minimum, means[:, 1]),
            (2, np.maximum, means[:, 0]),
            (3, np.maximum, means[:, 1]),
        ):
            reduce.at(self._boxes[:, column], slots, values)
        np.maximum.at(self._spreads, slots, spread)

    def _modelled(self, candidates: Candidates) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The particle-observation-slot triples of ``candidates`` to model, as particles,
        observations and candidate columns (E,) each: the particle holds the slot's landmark, the
        pair is ``near``, and (with ``candidates.points``) the landmark lies nearer than the pair's
        reach to where the particle puts the observation (otherwise the pair is beyond the
        new-landmark gate in that particle: ``_reach``), or the column is ``forced``.
        A few operations per particle of each near pair, on (Q, P) arrays (each pair's particles
        one contiguous row)."""
        p = len(self.poses)
        ks, columns = np.nonzero(candidates.near)  # the Q pairs
        wanted = np.ascontiguousarray(candidates.valid.T)[columns]  # (Q, P)
        points, reach2 = candidates.points, candidates.reach2
        if points is not None and reach2 is not None:
            means = np.take(self.means, candidates.slots, axis=1).transpose(2, 1, 0).copy()  # (2, C, P)
            gap = points[0, ks] - means[0, columns]
            gap_y = points[1, ks] - means[1, columns]
            gap *= gap
            gap_y *= gap_y
            gap += gap_y
            wanted &= gap < reach2[ks, columns, None]
        pairs, rows = np.divmod(np.flatnonzero(wanted), p)
        ks, columns = ks[pairs], columns[pairs]
        if candidates.forced is not None:  # added, each triple once
            forced_rows, forced_ks = np.nonzero(candidates.forced >= 0)
            k, c = candidates.near.shape
            flat = np.union1d(
                (rows * k + ks) * c + columns,
                (forced_rows * k + forced_ks) * c + candidates.forced[forced_rows, forced_ks],
            )
            rows, rest = np.divmod(flat, k * c)
            ks, columns = np.divmod(rest, c)
        return rows, ks, columns

    def _model(
        self,
        observations: np.ndarray,
        noise: np.ndarray,
        candidates: Candidates,
        with_pose_uncertainty: bool,
        facings: np.ndarray | None = None,
    ) -> MeasurementModel:
        """The measurement model of the ``candidates`` at the current poses (see
        ``MeasurementModel``); ``with_pose_uncertainty`` adds the motion covariance not yet drawn.
        With ``facings`` (K,) (rad, relative to the robot: the observed landmarks' directions), a
        pair whose landmark faces more than ``facing_gate`` away from its observation is ruled out
        (inf; a landmark or observation of unknown facing, NaN, is not).
        Computed for the triples ``_modelled`` keeps only, each one entry of flat (E,) arrays (the
        2x2 matrices written entry by entry; the landmarks gathered by flat index), so that the
        cost follows the landmarks near each particle's observations, not the candidate slots."""
        pairs = int(candidates.near.sum())
        rows, ks, columns = self._modelled(candidates)
        within_reach = len(rows)
        at = rows * self.means.shape[1] + candidates.slots[columns]  # flat (particle, slot) indexes
        poses = np.take(self.poses.T, rows, axis=1)  # (3, E)
        if (
            facings is not None
        ):  # first, so that the rest is computed for the triples it keeps; NaN compares False: kept
            apart = np.abs(ekf.wrap(poses[2] + facings[ks] - np.take(self.facings, at)))
            kept = np.flatnonzero(~(apart > math.radians(self.params.facing_gate)))
            rows, ks, columns, at, poses = rows[kept], ks[kept], columns[kept], at[kept], poses[:, kept]
        means = np.take(self.means.reshape(-1, 2), at, axis=0).T  # (2, E)
        dx, dy = means[0] - poses[0], means[1] - poses[1]
        q = np.maximum(dx * dx + dy * dy, 1e-12)
        rho = np.sqrt(q)
        a, b, c, d = dx / rho, dy / rho, -dy / q, dx / q  # H = d(range, bearing)/d(landmark)
        s00, s01, _, s11 = np.take(self.covariances.reshape(-1, 4), at, axis=0).T
        if with_pose_uncertainty:  # Gx = -[H | (0, 1)^T]: the pose's position adds to the landmark's covariance
            pose = self.pose_covariances.reshape(-1, 9)[:, [0, 1, 4, 2, 5, 8]].T  # (6, P): 00 01 11 02 12 22
            p00, p01, p11, p02, p12, p22 = np.take(pose, rows, axis=1)
            s00, s01, s11 = s00 + p00, s01 + p01, s11 + p11
        t00 = a * a * s00 + 2 * a * b * s01 + b * b * s11
        t01 = a * c * s00 + (a * d + b * c) * s01 + b * d * s11
        t11 = c * c * s00 + 2 * c * d * s01 + d * d * s11
        if with_pose_uncertainty:
            t01 = t01 + a * p02 + b * p12
            t11 = t11 + 2 * (c * p02 + d * p12) + p22
        t00 = t00 + noise[ks, 0, 0]
        t01 = t01 + noise[ks, 0, 1]
        t11 = t11 + noise[ks, 1, 1]
        det = t00 * t11 - t01 * t01
        if not ekf.positive_definite(t00, det):
            raise FilterDivergence(
                "the predicted covariance of an observation of a landmark is not positive definite", self.params
            )
        nu0 = observations[ks, 0] - rho
        nu1 = ekf.wrap(observations[ks, 1] - (np.arctan2(dy, dx) - poses[2]))  # the predicted bearing unwrapped
        # The model keeps the candidate columns with a triple left only (the others would be inf).
        present = np.zeros(len(candidates.slots), dtype=bool)
        present[columns] = True
        columns = (np.cumsum(present) - 1)[columns]
        candidates = Candidates(candidates.slots[present], candidates.valid[:, present], candidates.near[:, present])
        shape = (len(self.poses), len(observations), len(candidates.slots))
        triples = (rows * shape[1] + ks) * shape[2] + columns
        distance2 = np.full(shape, np.inf)
        distance2.reshape(-1)[triples] = (t11 * nu0 * nu0 - 2 * t01 * nu0 * nu1 + t00 * nu1 * nu1) / det
        return MeasurementModel(candidates, distance2, triples, det, pairs, within_reach)

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
        Steps: 1. associate (with the pose's uncertainty for FastSLAM 2.0) among the landmarks
        within reach; 2. draw the poses (FastSLAM 2.0); 3. update matched landmarks, start new
        ones and weigh the particles; 4. drop tentative landmarks that were missed; 5. resample
        when the weights degenerate.

        Raises ``FilterDivergence`` where the numbers first go bad (an observation noise,
        innovation or landmark covariance not positive definite, a pose or weight not finite),
        before numpy is asked to divide by them; the filter is not to be used after it.
        """
        observations = np.asarray(observations, dtype=float).reshape(-1, 2)
        report = UpdateReport(observations=len(observations))
        count = len(observations)
        known = self.params.association == Association.KNOWN
        if count and known and ids is None:
            raise ValueError("association='known' needs the observations' ids")
        if not math.isfinite(observations.sum()):  # a sum: NaN or inf anywhere makes it so
            raise ValueError("observations must be finite ranges and bearings")
        self._check_particles()
        while count and not self._has_room(count):  # for every observation to start a landmark
            self._grow()
        noise = self.params.inflation * self.params.observation_noise(covariances, count)
        if count and not (math.isfinite(noise.sum()) and _positive_definite(noise)):
            raise FilterDivergence(self._noise_problem(covariances), self.params)
        try:
            return self._update(observations, noise, ids, facings, report)
        except ekf.NotPositiveDefinite as error:
            raise FilterDivergence(str(error), self.params) from None

    def _check_particles(self) -> None:
        """Raise ``FilterDivergence`` unless every pose and log weight is finite (the weights then
        normalise: not all zero, none NaN). Two sums (a NaN or inf anywhere makes theirs so; poses
        and log weights of a sane size do not overflow): a few microseconds."""
        if math.isfinite(self.poses.sum() + self.log_weights.sum()):
            return
        if not np.isfinite(self.poses).all():
            raise FilterDivergence("a particle's pose is not finite", self.params)
        raise FilterDivergence("the particle weights are not finite", self.params)

    def _noise_problem(self, covariances) -> str:
        """Why the observation noise is not positive definite, in words."""
        if covariances is None:
            why = "these observations come without a covariance of their own (landmark records)"
        elif self.params.observation_scale == 0:
            why = "observation_scale = 0 leaves the observations' own covariances out"
        else:
            return "an observation's own covariance (times observation_scale) is not positive definite"
        return (
            f"the observation noise diag(sigmaR^2, sigmaB^2) is singular: {why}, so sigmaR and sigmaB are "
            "their whole noise and both must be above 0"
        )

    def _update(self, observations: np.ndarray, noise: np.ndarray, ids, facings, report: UpdateReport) -> UpdateReport:
        """``update``'s steps, with the observation noise ``noise`` (K, 2, 2) checked."""
        count = len(observations)
        known = self.params.association == Association.KNOWN
        relative_facings = None if facings is None else np.asarray(facings, dtype=float)
        # 1. Association among the candidates, under the model the weights use.
        m = self._used_slots()
        assigned = None
        if known and count:
            assigned = associate_known(np.asarray(ids), self.ids[:, :m], self.exists[:, :m])
        gated = assigned is None and relative_facings is not None and self.params.facing_gate < 180
        model = self._model(
            observations,
            noise,
            self._candidates(observations, noise, m, assigned),
            self.proposal.carries_pose_uncertainty,
            relative_facings if gated else None,
        )
        report.pairs, report.within_reach, report.modelled = model.pairs, model.within_reach, len(model.triples)
        if assigned is None:
            assigned = model.candidates.slots_of(associate_greedy(model.distance2, self.params.gate))
        # 2. The proposal's draw; the landmarks are then corrected at the drawn poses.
        self.poses, self.pose_covariances, joint = self.proposal.draw(
            self.poses, self.pose_covariances, assigned, observations, self.means, self.covariances, noise, self.rng
        )
        likelihood = joint if joint is not None else _associated_terms(model, assigned)
        report.nis, report.nis_observations = _normalised_innovations(likelihood[0], assigned, self.weights())
        # 3. Landmarks and weights.
        if count:
            matched_now = np.zeros_like(self.exists)
            new = self._new_observations(assigned, model, ids, report)
            self._weigh(assigned, new, likelihood, noise)
            self._check_particles()
            self._correct_landmarks(assigned, observations, noise, matched_now, report)
            self._add_landmarks(new, observations, noise, ids, relative_facings, matched_now)
            # 4. Tentative landmarks predicted in view but not seen.
            self._manage_landmarks(matched_now, report)
        # 5. Selective resampling.
        report.effective_sample_size = self.effective_sample_size()
        if report.effective_sample_size < self.params.resample_threshold * self.params.NPARTICLES:
            self.resample()
            report.resampled = True
        return report

    def _new_observations(self, assigned: np.ndarray, model: MeasurementModel, ids, report: UpdateReport):
        """(P, K) the unmatched observations that start a landmark: with unknown association those
        farther than ``new_landmark_gate`` from every landmark (the nearer ones are ambiguous and
        counted in ``report``); with known association those of an identity not yet mapped."""
        unmatched = assigned < 0
        if self.params.association == Association.KNOWN:
            new = unmatched & (np.asarray(ids)[None, :] >= 0)
        else:
            nearest = model.distance2.min(axis=2, initial=np.inf)
            new = unmatched & (nearest >= self.params.new_landmark_gate)
        report.ambiguous += int((unmatched & ~new).sum())
        report.new += int(new.sum())
        return new

    def _weigh(self, assigned: np.ndarray, new: np.ndarray, likelihood, noise: np.ndarray) -> None:
        """Multiply each particle's weight by its observations' likelihoods: for an associated one
        the Gaussian density of its innovation (``likelihood``: squared Mahalanobis distances and
        determinants (P, K)); for a new landmark the density at the edge of the new-landmark gate;
        each raised to ``likelihood_exponent``. Added observation by observation, in order."""
        matched = -0.5 * likelihood[0] - LOG_TWO_PI - 0.5 * np.log(likelihood[1])
        start = -0.5 * self.params.new_landmark_gate - LOG_TWO_PI - 0.5 * np.log(np.linalg.det(noise))  # (K,)
        terms = self.params.likelihood_exponent * np.where(assigned >= 0, matched, np.where(new, start[None, :], 0.0))
        for k in range(terms.shape[1]):
            self.log_weights += terms[:, k]

    def _correct_landmarks(
        self, assigned: np.ndarray, observations: np.ndarray, noise: np.ndarray, matched_now, report: UpdateReport
    ) -> None:
        """EKF-update every landmark slot ``assigned`` (P, K) to an observation, linearised at the
        poses the particles now have, all pairs at once. (A slot assigned twice in one scan, known
        association with a repeated identity, is updated once per observation, in order.)"""
        rows, ks = np.nonzero(assigned >= 0)
        slots = assigned[rows, ks]
        report.matched += len(rows)
        first = self._first_updates(rows, slots)
        while len(rows):
            r, k, j = rows[first], ks[first], slots[first]
            predicted, jacobian = ekf.range_bearing_landmark(self.poses[r], self.means[r, j])
            residual = ekf.innovation(observations[k], predicted)
            means, covariances, _ = ekf.update(self.means[r, j], self.covariances[r, j], residual, jacobian, noise[k])
            if not _positive_definite(covariances):
                raise FilterDivergence("a landmark's covariance is not positive definite after its update", self.params)
            self.means[r, j], self.covariances[r, j] = means, covariances
            self.seen[r, j] += 1
            self.missed[r, j] = 0
            matched_now[r, j] = True
            self._widen_index(r, j, means, covariances)
            rows, ks, slots = rows[~first], ks[~first], slots[~first]
            first = self._first_updates(rows, slots)

    def _first_updates(self, rows: np.ndarray, slots: np.ndarray) -> np.ndarray:
        """(n,) True for the first of the landmark updates ``rows``, ``slots`` (n,) of each
        landmark: all of them with unknown association, which assigns a slot at most once."""
        if self.params.association != Association.KNOWN:
            return np.ones(len(rows), dtype=bool)
        first = np.zeros(len(rows), dtype=bool)
        first[np.unique(rows * self.exists.shape[1] + slots, return_index=True)[1]] = True
        return first

    def _add_landmarks(self, new: np.ndarray, observations, noise, ids, facings, matched_now) -> None:
        """Initialise a landmark from each ``new`` (P, K) observation in its particle, in the
        particle's first free slots in order; ``ids`` (K,) and ``facings`` (K,) (rad, relative to
        the robot) are the observations' when known, else None."""
        rows, ks = np.nonzero(new)
        if not len(rows):
            return
        slots = self._free_slots(new.shape[1])[rows, np.cumsum(new, axis=1)[rows, ks] - 1]
        rho, bearing = observations[ks, 0], observations[ks, 1]
        angle = self.poses[rows, 2] + bearing
        cos_a, sin_a = np.cos(angle), np.sin(angle)
        self.means[rows, slots] = self.poses[rows, :2] + rho[:, None] * np.column_stack([cos_a, sin_a])
        # Inverse measurement Jacobian dm/d(rho, bearing), then Sigma = G R G^T.
        g = np.stack([np.stack([cos_a, -rho * sin_a], -1), np.stack([sin_a, rho * cos_a], -1)], -2)
        covariances = g @ noise[ks] @ np.swapaxes(g, -1, -2)
        if not _positive_definite(covariances):
            raise FilterDivergence("a new landmark's covariance is not positive definite", self.params)
        self.covariances[rows, slots] = covariances
        self.exists[rows, slots] = True
        self.seen[rows, slots] = 1
        self.missed[rows, slots] = 0
        self.ids[rows, slots] = -1 if ids is None else np.asarray(ids)[ks]
        self.facings[rows, slots] = np.nan if facings is None else wrap_angle(self.poses[rows, 2] + facings[ks])
        matched_now[rows, slots] = True
        self._widen_index(rows, slots)

    def _free_slots(self, count: int) -> np.ndarray:
        """The first ``count`` free slots (P, count) of every particle, ascending (update made room)."""
        free = ~self.exists[:, : self._used_slots() + count]
        rows, slots = np.nonzero(free & (np.cumsum(free, axis=1) <= count))
        return slots.reshape(len(free), count)

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
        self.reindex()

    def _has_room(self, count: int) -> bool:
        """Every particle has ``count`` free slots (surely so when the slots beyond the used ones do)."""
        return self.exists.shape[1] - self._used_slots() >= count or (~self.exists).sum(axis=1).min() >= count

    def _manage_landmarks(self, matched_now: np.ndarray, report: UpdateReport) -> None:
        """Count a miss for every tentative landmark (seen once, not matched now) within
        ``view_range`` of its particle's pose, and remove those missed ``tentative_limit`` times.
        Only the slots whose index box is that near the particles' box are looked at."""
        position = self.poses[:, :2]
        gaps = self._gaps(position.min(axis=0)[None], position.max(axis=0)[None], self._used_slots())[:, 0]
        columns = np.flatnonzero(gaps < self.params.view_range**2)
        tentative = self.exists[:, columns] & (self.seen[:, columns] <= 1) & ~matched_now[:, columns]
        rows, picked = np.nonzero(tentative)
        slots = columns[picked]
        delta = self.means[rows, slots] - self.poses[rows, :2]
        in_view = np.sqrt(np.maximum(delta[:, 0] ** 2 + delta[:, 1] ** 2, 1e-12)) < self.params.view_range
        rows, slots = rows[in_view], slots[in_view]
        self.missed[rows, slots] += 1
        remove = self.missed[rows, slots] >= self.params.tentative_limit
        report.removed += int(remove.sum())
        self.exists[rows[remove], slots[remove]] = False

    # -- weights ------------------------------------------------------------------------------
    def weights(self) -> np.ndarray:
        """Normalised particle weights (P,)."""
        return normalized_weights(self.log_weights)

    def effective_sample_size(self) -> float:
        return effective_sample_size(self.weights())

    def resample(self) -> None:
        """Low-variance (systematic) resampling, in place: only the particles that change are
        overwritten, and only in the landmark slots in use; weights become uniform."""
        targets, sources = resampling.changed_rows(resampling.systematic_resample(self.weights(), self.rng))
        held = np.flatnonzero(self.exists.any(axis=0))  # the slots beyond hold no landmark: not copied
        m = int(held[-1]) + 1 if len(held) else 0
        for name in ("means", "covariances", "exists", "seen", "missed", "ids", "facings"):
            array = getattr(self, name)
            array[targets, :m] = array[sources, :m]
        self.poses[targets] = self.poses[sources]
        self.pose_covariances[targets] = self.pose_covariances[sources]
        self.log_weights = np.full(len(self.poses), -math.log(len(self.poses)))
        self.resamplings += 1
        widths = np.maximum(self._boxes[:m, 2] - self._boxes[:m, 0], self._boxes[:m, 3] - self._boxes[:m, 1])
        self.reindex(np.flatnonzero(widths > REINDEX_WIDTH))  # slots that held far-apart landmarks

    # -- estimates ----------------------------------------------------------------------------
    def mean_pose(self, weights: np.ndarray | None = None) -> np.ndarray:
        """Weighted mean pose (3,); the heading is the circular mean. ``weights``: ``weights()``
        when at hand."""
        w = self.weights() if weights is None else weights
        x, y = w @ self.poses[:, 0], w @ self.poses[:, 1]
        theta = math.atan2(w @ np.sin(self.poses[:, 2]), w @ np.cos(self.poses[:, 2]))
        return np.array([x, y, theta])

    def pose_covariance(self) -> np.ndarray:
        """Covariance (3, 3) of the weighted particle cloud around ``mean_pose`` (heading
        differences wrapped); FastSLAM 2.0 adds the motion uncertainty not yet drawn."""
        w = self.weights()
        deviation = self.poses - self.mean_pose(w)
        deviation[:, 2] = wrap_angle(deviation[:, 2])
        covariance = np.einsum("pi,pj->ij", w[:, None] * deviation, deviation)  # twice as fast as one 3-operand einsum
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
    columns = model.candidates.columns_of(assigned)
    rows, observations = np.nonzero(columns >= 0)
    distance2, determinant = np.full(assigned.shape, np.nan), np.full(assigned.shape, np.nan)
    picked = columns[rows, observations]
    distance2[rows, observations] = model.distance2[rows, observations, picked]
    determinant[rows, observations] = model.det[rows, observations, picked]
    return distance2, determinant


def _normalised_innovations(
    distance2: np.ndarray, assigned: np.ndarray, weights: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """NIS (A,) of the observations that most of the weight associates, and their indexes (A,)
    among the scan's observations: for observation k, the weight-averaged squared Mahalanobis
    distance ``distance2`` (P, K) over the particles whose ``assigned`` (P, K) slot is not -1, with
    their normalised ``weights`` (P,) before the scan."""
    values, indexes = [], []
    for k in range(assigned.shape[1]):
        rows = np.flatnonzero(assigned[:, k] >= 0)
        if weights[rows].sum() > 0.5:
            values.append(np.average(distance2[rows, k], weights=weights[rows]))
            indexes.append(k)
    return np.asarray(values, dtype=float), np.asarray(indexes, dtype=np.int64)


def _positive_definite(matrices: np.ndarray) -> bool:
    """Every 2x2 matrix of ``matrices`` (n, 2, 2) (covariances: symmetric) is positive definite."""
    a, b, d = matrices[:, 0, 0], matrices[:, 0, 1], matrices[:, 1, 1]
    return ekf.positive_definite(a, a * d - b * b)
