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
    pose_covariances (P, 3, 3) FastSLAM 2.0 only: covariance of the motion since the last scan;
                               ``poses`` then holds the mean of that motion until a scan samples it

Observations are range and bearing ``z = (rho, phi)`` of a point landmark in the robot frame; the
measurement model is ``h(x, m) = (|m - x|, atan2(m_y - y, m_x - x) - theta)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mazeslam.config import require
from mazeslam.filters.motion import predict_odometry, predict_relative, relative_motion_covariance
from mazeslam.geometry import advance_pose, compose, wrap_angle

LOG_TWO_PI = math.log(2 * math.pi)


@dataclass(frozen=True)
class FastSLAMParams:
    """Filter settings, named as in the exercise's control_panel.m where it has them.

    The odometry defaults follow from the simulator's wheel slip (0.003 m per sqrt(m) per wheel,
    wheelbase 53 mm) with a 25 % margin: distance 0.003/sqrt(2), heading from driving
    0.003 sqrt(2)/0.053, heading from turning on the spot 0.003/sqrt(0.053) (each per square root of
    the motion).

    Attributes:
        NPARTICLES: number of particles.
        sigmaX: odometry distance noise, m per sqrt(m) travelled.
        sigmaTH: odometry heading noise from turning, rad per sqrt(rad) turned.
        sigmaTH_drive: odometry heading noise from driving, rad per sqrt(m) travelled.
        sigmaR, sigmaB: range (m) and bearing (rad) noise of an observation; with
            ``use_observation_covariance`` added to the covariance the corner extractor reports,
            which already carries the laser's range noise, so the defaults are small (1 mm,
            0.29 degrees): 3 mm and 1 degree counted that noise twice and doubled the aligned
            ATE over 20 seeds (docs/fastslam.md).
        use_observation_covariance: use each observation's own covariance (from the line fits).
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
        seed: seeds the filter's random draws.
    """

    NPARTICLES: int = 100
    sigmaX: float = 0.0027
    sigmaTH: float = 0.017
    sigmaTH_drive: float = 0.1
    sigmaR: float = 0.001
    sigmaB: float = 0.005
    use_observation_covariance: bool = True
    gate: float = 9.21
    new_landmark_gate: float = 16.0
    resample_threshold: float = 0.5
    association: str = "unknown"
    view_range: float = 0.25
    tentative_limit: int = 3
    version: int = 1
    seed: int = 0

    def __post_init__(self):
        require(self.NPARTICLES >= 1, f"NPARTICLES must be at least 1, got {self.NPARTICLES}")
        for name in ("sigmaX", "sigmaTH", "sigmaTH_drive", "sigmaR", "sigmaB"):
            require(getattr(self, name) >= 0, f"{name} must be >= 0, got {getattr(self, name)}")
        require(self.sigmaR > 0 or self.use_observation_covariance,
                "sigmaR must be positive unless use_observation_covariance is on")
        require(0 < self.gate <= self.new_landmark_gate,
                f"need 0 < gate <= new_landmark_gate, got {self.gate} and {self.new_landmark_gate}")
        require(0 <= self.resample_threshold <= 1, f"resample_threshold must be in [0, 1], got {self.resample_threshold}")
        require(self.association in ("unknown", "known"), f"association must be 'unknown' or 'known', got {self.association!r}")
        require(self.view_range >= 0 and self.tentative_limit >= 1, "view_range must be >= 0 and tentative_limit >= 1")
        require(self.version in (1, 2), f"version must be 1 or 2 (FastSLAM 1.0 or 2.0), got {self.version}")


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


class FastSLAM:
    """The filter. ``predict`` with each odometry record, ``update`` with each scan's observations."""

    def __init__(self, params: FastSLAMParams, start_pose=(0.0, 0.0, 0.0), capacity: int = 32):
        self.params = params
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
        self.pose_covariances = np.zeros((p, 3, 3))
        self.resamplings = 0

    # -- motion -----------------------------------------------------------------------------
    def predict(self, distance: float, turn: float) -> None:
        """Move every particle by an odometry increment (metres, radians).

        FastSLAM 1.0 draws each particle's noise now. FastSLAM 2.0 moves the particles' means
        without noise and accumulates the motion's covariance, to be combined with the next scan's
        observations (``update``) before a pose is drawn.
        """
        p = self.params
        if p.version == 1:
            self.poses = predict_odometry(self.poses, distance, turn, p.sigmaX, p.sigmaTH, p.sigmaTH_drive, self.rng)
            return
        if distance == 0.0 and turn == 0.0:
            return
        heading = self.poses[:, 2] + 0.5 * turn
        cos_h, sin_h = np.cos(heading), np.sin(heading)
        count = len(self.poses)
        # Jacobians of advance_pose with respect to the pose (F) and to (distance, turn) (V).
        f = np.tile(np.eye(3), (count, 1, 1))
        f[:, 0, 2], f[:, 1, 2] = -distance * sin_h, distance * cos_h
        v = np.zeros((count, 3, 2))
        v[:, 0, 0], v[:, 1, 0] = cos_h, sin_h
        v[:, 0, 1], v[:, 1, 1], v[:, 2, 1] = -0.5 * distance * sin_h, 0.5 * distance * cos_h, 1.0
        motion = np.diag([p.sigmaX**2 * abs(distance), p.sigmaTH**2 * abs(turn) + p.sigmaTH_drive**2 * abs(distance)])
        self._carry_motion_covariance(f, v, motion)
        self.poses = advance_pose(self.poses, distance, turn)

    def predict_relative(self, increment) -> None:
        """Move every particle by a relative motion ``increment`` (dx, dy, dtheta) given in its own
        robot frame (laser odometry), with the noise of ``relative_motion_covariance``.

        As in ``predict``, FastSLAM 1.0 draws the noise now and FastSLAM 2.0 accumulates the
        motion's covariance for the next scan's proposal.
        """
        p = self.params
        increment = np.asarray(increment, dtype=float)
        motion = relative_motion_covariance(increment, p.sigmaX, p.sigmaTH, p.sigmaTH_drive)
        if p.version == 1:
            self.poses = predict_relative(self.poses, increment, motion, self.rng)
            return
        cos_t, sin_t = np.cos(self.poses[:, 2]), np.sin(self.poses[:, 2])
        count = len(self.poses)
        # Jacobians of compose(pose, increment) with respect to the pose (F) and the increment (V).
        f = np.tile(np.eye(3), (count, 1, 1))
        f[:, 0, 2] = -sin_t * increment[0] - cos_t * increment[1]
        f[:, 1, 2] = cos_t * increment[0] - sin_t * increment[1]
        v = np.tile(np.eye(3), (count, 1, 1))
        v[:, 0, 0], v[:, 0, 1], v[:, 1, 0], v[:, 1, 1] = cos_t, -sin_t, sin_t, cos_t
        self._carry_motion_covariance(f, v, motion)
        self.poses = compose(self.poses, increment)

    def _carry_motion_covariance(self, f: np.ndarray, v: np.ndarray, motion: np.ndarray) -> None:
        """FastSLAM 2.0: propagate each particle's motion covariance through one motion, F Sigma F^T
        + V Q V^T, with F (P, 3, 3) and V (P, 3, k) the motion's Jacobians with respect to the pose
        and to its k noisy terms, and Q (k, k) their covariance."""
        self.pose_covariances = f @ self.pose_covariances @ np.swapaxes(f, 1, 2) + v @ motion @ np.swapaxes(v, 1, 2)

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

    def _noise(self, covariances: np.ndarray | None, count: int) -> np.ndarray:
        """Observation noise R (K, 2, 2): the fixed sigmaR/sigmaB plus each observation's own."""
        fixed = np.diag([self.params.sigmaR**2, self.params.sigmaB**2])
        if covariances is None or not self.params.use_observation_covariance:
            return np.broadcast_to(fixed, (count, 2, 2)).copy()
        return np.asarray(covariances, dtype=float) + fixed

    # -- update -------------------------------------------------------------------------------
    def update(self, observations: np.ndarray, covariances: np.ndarray | None = None,
               ids: np.ndarray | None = None) -> UpdateReport:
        """Weigh and correct every particle with one scan's observations.

        Args:
            observations: (K, 2) range (m) and bearing (rad) in the robot frame.
            covariances: (K, 2, 2) their covariances, or None.
            ids: (K,) known landmark identities (``association="known"``; -1: none, the observation
                is left out and counted as ambiguous), else None.
        """
        observations = np.asarray(observations, dtype=float).reshape(-1, 2)
        report = UpdateReport(observations=len(observations))
        count = len(observations)
        if count and self.params.association == "known" and ids is None:
            raise ValueError("association='known' needs the observations' ids")
        while count and (~self.exists).sum(axis=1).min() < count:  # room for every observation to start a landmark
            self._grow()
        noise = self._noise(covariances, count)
        m = self._used_slots()
        two = self.params.version == 2
        prior = self._model(observations, noise, m, with_pose_uncertainty=two)
        if self.params.association == "known" and count:
            assigned = self._associate_known(np.asarray(ids), m)
        else:
            assigned = self._associate(prior["distance2"])
        if two:
            self._draw_poses(assigned, observations, noise)
        model = self._model(observations, noise, m, with_pose_uncertainty=False) if two else prior
        matched_now = np.zeros_like(self.exists)
        for k in range(count):
            self._apply(k, assigned[:, k], model, prior, observations[k], noise[k], ids, matched_now, report)
        if count:
            self._manage_landmarks(model["rho"], matched_now, report)
        report.effective_sample_size = self.effective_sample_size()
        if report.effective_sample_size < self.params.resample_threshold * self.params.NPARTICLES:
            self.resample()
            report.resampled = True
        return report

    def _model(self, observations: np.ndarray, noise: np.ndarray, m: int, with_pose_uncertainty: bool) -> dict:
        """The measurement model of the first ``m`` slots at the current poses.

        Returns a dict of arrays: ``rho``, ``bearing`` (P, m); ``h`` the landmark Jacobian's entries
        (a, b, c, d), each (P, m); ``base`` the entries (00, 01, 11) of H Sigma H^T, each (P, m);
        ``nu`` the innovations (range, bearing), each (P, K, m); ``det`` and ``distance2`` of
        S = H Sigma H^T + R (+ Gx Sigma_x Gx^T with the pose's uncertainty), each (P, K, m).
        """
        rho, bearing, h = self._predicted(m)
        a, b, c, d = h
        sigma = self.covariances[:, :m]
        s00, s01, s11 = sigma[..., 0, 0], sigma[..., 0, 1], sigma[..., 1, 1]
        base = (a * a * s00 + 2 * a * b * s01 + b * b * s11,
                a * c * s00 + (a * d + b * c) * s01 + b * d * s11,
                c * c * s00 + 2 * c * d * s01 + d * d * s11)
        t00, t01, t11 = base
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
        return {"rho": rho, "bearing": bearing, "h": h, "base": base, "nu": (nu0, nu1), "det": det,
                "distance2": distance2}

    def _draw_poses(self, assigned: np.ndarray, observations: np.ndarray, noise: np.ndarray) -> None:
        """FastSLAM 2.0's proposal: each particle's motion Gaussian (mean ``poses``, covariance
        ``pose_covariances``) is corrected by its associated observations, one EKF step each, and
        the pose is drawn from the result."""
        mean, covariance = self.poses.copy(), self.pose_covariances.copy()
        for k in range(len(observations)):
            rows = np.flatnonzero(assigned[:, k] >= 0)
            if not len(rows):
                continue
            j = assigned[rows, k]
            delta = self.means[rows, j] - mean[rows, :2]
            dx, dy = delta[:, 0], delta[:, 1]
            q = np.maximum(dx * dx + dy * dy, 1e-12)
            rho = np.sqrt(q)
            h = np.stack([np.stack([dx / rho, dy / rho], -1), np.stack([-dy / q, dx / q], -1)], -2)  # (n, 2, 2)
            gx = np.concatenate([-h, np.stack([np.zeros(len(rows)), -np.ones(len(rows))], -1)[..., None]], -1)
            q_matrix = h @ self.covariances[rows, j] @ np.swapaxes(h, -1, -2) + noise[k]
            sigma = covariance[rows]
            s = gx @ sigma @ np.swapaxes(gx, -1, -2) + q_matrix
            gain = sigma @ np.swapaxes(gx, -1, -2) @ np.linalg.inv(s)  # (n, 3, 2)
            nu = np.column_stack([observations[k, 0] - rho,
                                  wrap_angle(observations[k, 1] - (np.arctan2(dy, dx) - mean[rows, 2]))])
            mean[rows] += np.einsum("nij,nj->ni", gain, nu)
            corrected = (np.eye(3) - gain @ gx) @ sigma
            covariance[rows] = 0.5 * (corrected + np.swapaxes(corrected, -1, -2))
        values, vectors = np.linalg.eigh(covariance)
        draws = self.rng.standard_normal(mean.shape) * np.sqrt(np.clip(values, 0, None))
        self.poses = mean + np.einsum("pij,pj->pi", vectors, draws)
        self.poses[:, 2] = wrap_angle(self.poses[:, 2])
        self.pose_covariances = np.zeros_like(covariance)

    def _associate(self, distance2: np.ndarray) -> np.ndarray:
        """Greedy one-to-one maximum-likelihood association per particle: (P, K) landmark slot or -1.

        Repeatedly takes the closest (Mahalanobis) observation-landmark pair within the gate, so two
        observations never update one landmark, and the second is not silently lost: it competes
        for the next closest landmark or becomes new/ambiguous.
        """
        p, k, m = distance2.shape
        assigned = np.full((p, k), -1)
        if m == 0:
            return assigned
        remaining = distance2.copy()
        rows = np.arange(p)
        for _ in range(min(k, m)):
            flat = remaining.reshape(p, -1).argmin(axis=1)
            obs, slot = np.divmod(flat, m)
            ok = remaining[rows, obs, slot] < self.params.gate
            if not ok.any():
                break
            assigned[rows[ok], obs[ok]] = slot[ok]
            remaining[rows[ok], obs[ok], :] = np.inf
            remaining[rows[ok], :, slot[ok]] = np.inf
        return assigned

    def _associate_known(self, ids: np.ndarray, m: int) -> np.ndarray:
        """(P, K) the slot (among the first m) holding each observation's identity, or -1."""
        if m == 0:
            return np.full((len(self.poses), len(ids)), -1)
        match = (self.ids[:, None, :m] == ids[None, :, None]) & self.exists[:, None, :m] & (ids[None, :, None] >= 0)
        return np.where(match.any(axis=2), match.argmax(axis=2), -1)

    def _apply(self, k, slots, model, prior, observation, noise, ids, matched_now, report) -> None:
        """EKF-update the landmarks matched by observation k, start new ones, and weigh the particles.

        ``model`` linearises at the poses the particles now have; ``prior`` is the model the
        association used, whose Mahalanobis distances weigh the particles (the same dict for
        FastSLAM 1.0; for 2.0 it includes the motion's uncertainty, before the pose was drawn).
        """
        distance2 = prior["distance2"]
        rows = np.flatnonzero(slots >= 0)
        if len(rows):
            j = slots[rows]
            h = np.stack([np.stack([model["h"][0][rows, j], model["h"][1][rows, j]], -1),
                          np.stack([model["h"][2][rows, j], model["h"][3][rows, j]], -1)], -2)  # (n, 2, 2)
            base00, base01, base11 = (entry[rows, j] for entry in model["base"])
            t00, t01, t11 = base00 + noise[0, 0], base01 + noise[0, 1], base11 + noise[1, 1]
            det = t00 * t11 - t01 * t01
            s_inv = np.stack([np.stack([t11, -t01], -1), np.stack([-t01, t00], -1)], -2) / det[:, None, None]
            sigma = self.covariances[rows, j]
            gain = sigma @ np.swapaxes(h, -1, -2) @ s_inv  # (n, 2, 2)
            nu = np.column_stack([model["nu"][0][rows, k, j], model["nu"][1][rows, k, j]])
            self.means[rows, j] += np.einsum("nij,nj->ni", gain, nu)
            identity_minus = np.eye(2) - gain @ h
            # Joseph form keeps the covariance symmetric and positive definite.
            self.covariances[rows, j] = (identity_minus @ sigma @ np.swapaxes(identity_minus, -1, -2)
                                         + gain @ noise @ np.swapaxes(gain, -1, -2))
            self.log_weights[rows] += (-0.5 * distance2[rows, k, j] - LOG_TWO_PI
                                       - 0.5 * np.log(prior["det"][rows, k, j]))
            self.seen[rows, j] += 1
            self.missed[rows, j] = 0
            matched_now[rows, j] = True
            report.matched += len(rows)
        unmatched = slots < 0
        nearest = distance2[:, k].min(axis=1, initial=np.inf)
        if self.params.association == "known":  # an identity not yet mapped starts a landmark; none (-1): left out
            new = unmatched & (ids[k] >= 0)
        else:
            new = unmatched & (nearest >= self.params.new_landmark_gate)
        report.ambiguous += int((unmatched & ~new).sum())
        if new.any():
            self._add_landmarks(np.flatnonzero(new), observation, noise, None if ids is None else ids[k], matched_now)
            # A new landmark's likelihood: the density at the edge of the new-landmark gate.
            self.log_weights[new] += -0.5 * self.params.new_landmark_gate - LOG_TWO_PI - 0.5 * math.log(
                np.linalg.det(noise))
            report.new += int(new.sum())

    def _add_landmarks(self, rows: np.ndarray, observation, noise, identity, matched_now) -> None:
        """Initialise a landmark from one observation in each particle of ``rows``."""
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

    def _manage_landmarks(self, predicted_range: np.ndarray, matched_now: np.ndarray, report: UpdateReport) -> None:
        """Count misses of tentative landmarks predicted in view (``predicted_range`` (P, m) of the
        slots that existed before this scan), and remove repeatedly missed ones."""
        m = predicted_range.shape[1]
        in_view = (self.exists[:, :m] & (self.seen[:, :m] <= 1) & ~matched_now[:, :m]
                   & (predicted_range < self.params.view_range))
        self.missed[:, :m][in_view] += 1
        remove = self.exists & (self.missed >= self.params.tentative_limit)
        report.removed += int(remove.sum())
        self.exists[remove] = False

    # -- weights ------------------------------------------------------------------------------
    def weights(self) -> np.ndarray:
        """Normalised particle weights (P,), computed in log space: never NaN, even if every
        likelihood underflows."""
        shifted = self.log_weights - self.log_weights.max()
        weights = np.exp(shifted)
        return weights / weights.sum()

    def effective_sample_size(self) -> float:
        weights = self.weights()
        return float(1.0 / np.sum(weights**2))

    def resample(self) -> None:
        """Low-variance (systematic) resampling; weights become uniform."""
        p = self.params.NPARTICLES
        positions = (self.rng.random() + np.arange(p)) / p
        cumulative = np.cumsum(self.weights())
        cumulative[-1] = 1.0
        index = np.searchsorted(cumulative, positions)
        for name in ("poses", "means", "covariances", "exists", "seen", "missed", "ids", "pose_covariances"):
            setattr(self, name, getattr(self, name)[index])
        self.log_weights = np.full(p, -math.log(p))
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

