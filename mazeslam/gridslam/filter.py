"""Grid-map Rao-Blackwellised particle filter (Grisetti, Stachniss and Burgard, "Improved techniques
for grid mapping with Rao-Blackwellized particle filters", IEEE T-RO 2007: the method of gmapping).

Each particle is a robot pose, a log weight and its own occupancy grid (its tiles in the cloud's
``TilePool``, shared copy-on-write with its relatives). A scan is processed once the robot has
moved ``linear_update`` metres or turned ``angular_update`` radians since the last processed scan,
with the motion accumulated in between (``u``). For each particle, at its previous pose ``x'``:

1. predict ``x^ = x' (+) u`` and match the scan against the particle's own map from there
   (``refine_pose``: likelihood field times the motion prior ``N(x^, Q(u))``), giving the mode ``x*``;
2. score ``K = 27`` poses ``x_j`` on a 3 x 3 x 3 stencil around ``x*``:
   ``tau_j = p(z | m, x_j) p(x_j | x', u)``; the proposal is the Gaussian with their
   ``tau``-weighted mean and covariance, and the new pose is drawn from it;
3. the weight is multiplied by the normaliser ``eta = sum_j tau_j``.

When the refinement ends with too few end points near occupied cells (the laser odometry
can be wrong by decimetres and tenths of a radian where a scan alone is ambiguous), an exhaustive
correlative search over a wide window around ``x^`` (``mazeslam.registration.correlative``, against
the particle's occupied cells) seeds the refinement again. With ``search = "every-scan"`` the search
runs once at every scan, over a wider window (``every_scan_sigma``), for logs whose motion between
scans can be a metre or a right angle wrong (a laser odometry matched without wheel odometry).
When the match still fails the stencil is centred on ``x^`` for the weight and the pose is drawn
from the motion model. Then the scan is ray-traced into the particle's map at its new pose. The
matches, the stencils and the ray tracing run for all particles in one compiled call each
(``mazeslam.gridslam.kernels``: ``match_all``, ``integrate_all``); a particle whose match fails,
and every particle with the search at every scan, goes through the rescue and refinements one by
one. Weights are tempered as gmapping
does (log weights divided by ``observation_gain`` times the particle count) and the particles are
resampled (systematic) only when the effective sample size falls below ``resample_threshold``
times their count.

The motion ``u`` between scans comes from the project's laser odometry (``laser_odometry``, scan to
scan ICP with the wheel odometry as prior), or from the log's odometry records alone.
"""

from __future__ import annotations

import enum
import itertools
import time
from dataclasses import dataclass, field

import numpy as np

from mazeslam.core.beams import BeamGeometry
from mazeslam.core.config import check_setting, require
from mazeslam.core.geometry import advance_pose, compose, relative, wrap_angle
from mazeslam.core.motion import OdometryNoise, carried_to_records, dead_reckoning
from mazeslam.core.resampling import effective_sample_size, normalized_weights, systematic_resample
from mazeslam.data.log import CourseLog
from mazeslam.gridslam.matching import (
    DistanceMemo,
    LikelihoodField,
    MatchParams,
    field_reach,
    kernel_settings,
    match_points,
    match_pose,
    refine_pose,
)
from mazeslam.gridslam.occupancy import GridParams, ScanRays, TiledGrid, crop_cells, scan_rays, tile_range
from mazeslam.gridslam.tile_pool import TilePool
from mazeslam.registration.correlative import CorrelativeParams, LikelihoodGrid, correlative_candidates
from mazeslam.registration.scan_matching import ScanMatchParams, laser_odometry


class SearchMode(enum.StrEnum):
    """When the grid filter runs its wide correlative search (``GridSlamParams.search``)."""

    FAILED_MATCH = "failed-match"  #: for a particle whose scan match fails, over its own map
    EVERY_SCAN = "every-scan"  #: once a scan, over the best particle's map, seeding every particle's match


class MotionSource(enum.StrEnum):
    """Where the grid filter's motion between scans comes from (``GridSlamParams.motion``)."""

    LASER = "laser"  #: the laser odometry (scan-to-scan matching, the wheels as its prior)
    WHEELS = "wheels"  #: the log's odometry records chained, at each scan's own time


@dataclass(frozen=True)
class GridSlamParams:
    """Settings of the grid filter.

    Attributes:
        particles: particle count.
        seed: seed of the filter's random draws.
        grid: the occupancy grid (``GridParams``); match: the matcher (``MatchParams``).
        motion_noise: noise of the motion ``u`` between processed scans (``OdometryNoise``:
            sigmaX m/sqrt(m), sigmaTH rad/sqrt(rad), sigmaTH_drive rad/sqrt(m)), plus
            ``motion_floor`` (m and rad) on each axis. Its x and y variances are equal, so it is the
            same in the robot and the world frame. The default is the laser odometry's noise
            measured against the reference poses of the CARMEN logs (the median of the per-log fits,
            experiments/carmen_grid/results/motion_noise.md; ``mazeslam odometry-noise`` on one
            log), the floor its prior's (``ScanMatchParams.prior_floor``). The motion NIS
            (``motion_nis``, printed by the slam command) checks them on any log.
        linear_update, angular_update: a scan is processed after this much travel (m) or turning
            (rad) since the last processed scan; others only carry the motion on.
        kernel_step: spacing (x m, y m, theta rad) of the 3 x 3 x 3 stencil around the match.
        resample_threshold: resample when the effective sample size is below this fraction.
        observation_gain: log weights are divided by this times the particle count (gmapping's
            obsSigmaGain), as the beams of a scan are far from independent.
        window_margin: the map window read around a scan's reach, and the likelihood field around
            its matched end points, m (bounds the match's shift).
        rescue: the correlative search run when a refinement fails; rescue_sigma (m, rad) its
            window's standard deviation in position and heading (it reaches ``rescue.window_sigmas``
            of them) and the refinements' prior from its candidates.
        search: when the wide search runs (``SearchMode``): for a particle whose refinement fails,
            over its own map, or once at every scan, over the best particle's map (every particle
            then refines from its prediction and from the search's poses moved onto it, keeping
            the best, and the failed-match rescue does not run).
        every_scan_sigma: standard deviations (m, rad) of the every-scan search's window (it
            reaches ``rescue.window_sigmas`` of them) and of the prior its refinements are chosen
            by; the proposal's stencil and the weights keep ``motion_noise``'s prior around the motion.
        motion: where the motion between scans comes from (``MotionSource``): the laser odometry
            (settings ``laser_odometry``, ``[scan_matching]``) or the log's odometry records chained.
    """

    particles: int = 30
    seed: int = 0
    grid: GridParams = field(default_factory=GridParams)
    match: MatchParams = field(default_factory=MatchParams)
    motion_noise: OdometryNoise = field(default_factory=lambda: OdometryNoise(0.04, 0.02, 0.008))
    motion_floor: float = 0.01
    linear_update: float = 0.5
    angular_update: float = 0.25
    kernel_step: tuple = (0.02, 0.02, 0.01)
    resample_threshold: float = 0.5
    observation_gain: float = 3.0
    window_margin: float = 1.5
    rescue: CorrelativeParams = field(
        default_factory=lambda: CorrelativeParams(resolution=0.1, sigma=0.1, turn_step=2.0, candidates=3, max_points=90)
    )
    rescue_sigma: tuple = (0.4, 0.3)
    search: SearchMode = SearchMode.FAILED_MATCH
    every_scan_sigma: tuple = (0.4, 0.7)
    motion: MotionSource = MotionSource.LASER
    laser_odometry: ScanMatchParams = field(default_factory=lambda: ScanMatchParams(enabled=True))

    def __post_init__(self):
        object.__setattr__(self, "kernel_step", tuple(self.kernel_step))
        object.__setattr__(self, "rescue_sigma", tuple(self.rescue_sigma))
        object.__setattr__(self, "every_scan_sigma", tuple(self.every_scan_sigma))
        require(self.particles >= 1, "particles must be at least 1")
        object.__setattr__(self, "search", check_setting(SearchMode, "search", self.search, "GridSlamParams"))
        object.__setattr__(self, "motion", check_setting(MotionSource, "motion", self.motion, "GridSlamParams"))
        for name in ("rescue_sigma", "every_scan_sigma"):
            value = getattr(self, name)
            require(len(value) == 2 and all(v > 0 for v in value), f"{name}: 2 positive values (m, rad), got {value}")
        require(self.linear_update >= 0 and self.angular_update >= 0, "update thresholds must be >= 0")
        require(len(self.kernel_step) == 3 and all(s > 0 for s in self.kernel_step), "kernel_step: 3 positive steps")
        require(0 <= self.resample_threshold <= 1, "resample_threshold must be a fraction")
        require(
            self.observation_gain > 0 and self.motion_floor > 0, "observation_gain and motion_floor must be positive"
        )

    @property
    def rescue_covariance(self) -> np.ndarray:
        """Covariance (3, 3) of the rescue search's window (see ``rescue_sigma``)."""
        return _window_covariance(self.rescue_sigma)

    @property
    def every_scan_covariance(self) -> np.ndarray:
        """Covariance (3, 3) of the search's window when it runs at every scan (``every_scan_sigma``)."""
        return _window_covariance(self.every_scan_sigma)

    def motion_covariance(self, motion: np.ndarray) -> np.ndarray:
        """Covariance (3, 3) of a motion ``(dx, dy, dtheta)`` between processed scans."""
        return self.motion_noise.relative_covariance(motion) + self.motion_floor**2 * np.eye(3)


def _window_covariance(sigma: tuple) -> np.ndarray:
    """Diagonal covariance (3, 3) of a search window with standard deviations ``(m, rad)``."""
    xy, theta = sigma
    return np.diag([xy**2, xy**2, theta**2])


class GridDivergence(ValueError):
    """The grid filter's numbers went bad: a particle's pose or weight that is not finite (a motion
    or a scan the settings cannot take). A ``ValueError``: the command line prints it as one line."""


def _check_finite(poses: np.ndarray, log_weights: np.ndarray, motion: np.ndarray) -> None:
    """Raise ``GridDivergence``, in words, where a pose of ``poses`` (P, 3) or a weight of
    ``log_weights`` (P,) is not finite after ``motion`` (3,)."""
    bad_poses, bad_weights = np.sum(~np.isfinite(poses).all(axis=1)), np.sum(~np.isfinite(log_weights))
    if bad_poses or bad_weights:
        raise GridDivergence(
            f"the grid filter diverged: {bad_poses} of {len(poses)} particles' poses and {bad_weights} weights are "
            f"not finite after a motion of {np.round(motion, 4)} (m, m, rad); check the log's odometry there and "
            "[grid] motion_noise"
        )


@dataclass(frozen=True)
class ScanUpdate:
    """What one processed scan did to the cloud.

    Attributes:
        matched: share of the particles whose match was accepted.
        nis: the motion's normalised innovation squared (``motion_nis``), averaged over the
            particles whose match was accepted with their weights before the scan (NaN when
            less than half the weight matched).
        neff: effective sample size after the scan's weighting, before any resampling.
        indexes: (P,) the resampling's kept particles, or None without resampling.
    """

    matched: float
    nis: float
    neff: float
    indexes: np.ndarray | None


def motion_nis(matched: np.ndarray, predicted: np.ndarray, covariance: np.ndarray):
    """How far the scan match moved a particle from its prediction, against the motion's noise:
    ``d^T Q^-1 d`` for ``d = matched - predicted`` (3,) (world frame, heading wrapped; (P, 3) for
    several particles, giving (P,)) and the
    motion's covariance ``Q`` (3, 3) (x and y variances equal, so it is the same in the world
    frame). Where ``Q`` states the laser odometry's error right, it averages 3 (3 degrees of
    freedom, chi-square 95 % point 7.81): much less, ``Q`` is wider than the errors the scans
    correct; much more, narrower. It needs no truth."""
    offset = np.asarray(matched - predicted, dtype=float)
    offset[..., 2] = wrap_angle(offset[..., 2])
    values = np.einsum(
        "...i,...i->...", offset, np.linalg.solve(covariance, offset.reshape(-1, 3).T).T.reshape(offset.shape)
    )
    return float(values) if offset.ndim == 1 else values


def _weighted_nis(nis: np.ndarray, weights: np.ndarray) -> float:
    """The ``weights``-average (P,) of the particles' finite ``nis`` (P,); NaN when those hold less
    than half the weight."""
    finite = np.isfinite(nis)
    if weights[finite].sum() <= 0.5:
        return float("nan")
    return float(np.average(nis[finite], weights=weights[finite]))


#: The stencil of the proposal: every combination of -1, 0, +1 steps in x, y and theta, (27, 3).
STENCIL = np.array(list(itertools.product((-1.0, 0.0, 1.0), repeat=3)))


def gaussian(mean: np.ndarray, covariance: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """A draw (..., 3) from ``N(mean, covariance)`` (..., 3), (..., 3, 3) made of a standard normal
    draw ``normal`` (..., 3), as numpy's ``multivariate_normal(method="eigh")`` makes it (one
    decomposition per matrix of the stack)."""
    values, vectors = np.linalg.eigh(covariance)
    factor = vectors * np.sqrt(np.abs(values))[..., None, :]
    return mean + np.einsum("...j,...ij->...i", normal, factor)


@dataclass(frozen=True)
class Proposal:
    """One particle's improved proposal.

    Attributes:
        centre: (3,) the stencil's centre, world frame: the match where it was accepted, else the
            prediction.
        log_eta: log of the proposal's normaliser ``sum_j tau_j`` (the particle's weight factor).
        accepted: the match was accepted (enough end points near walls).
        mean, covariance: (3,), (3, 3) the ``tau``-weighted moments of the stencil's steps.
    """

    centre: np.ndarray
    log_eta: float
    accepted: bool
    mean: np.ndarray
    covariance: np.ndarray


@dataclass
class Proposals:
    """Every particle's improved proposal (``Proposal``'s fields, one row a particle).

    Attributes:
        centres: (P, 3) the stencils' centres, world frame (zero where nothing was matched).
        log_etas: (P,) the weight factors (0 where nothing was matched).
        accepted: (P,) bool the match was accepted.
        means, covariances: (P, 3), (P, 3, 3) the stencils' moments where accepted.
    """

    centres: np.ndarray
    log_etas: np.ndarray
    accepted: np.ndarray
    means: np.ndarray
    covariances: np.ndarray

    @classmethod
    def empty(cls, predicted: np.ndarray) -> Proposals:
        """No particle matched: zeros for each of ``predicted`` (P, 3)."""
        count = len(predicted)
        zeros = np.zeros((count, 3))
        return cls(zeros, np.zeros(count), np.zeros(count, dtype=bool), zeros.copy(), np.zeros((count, 3, 3)))

    def set(self, index: int, proposal: Proposal) -> None:
        """Particle ``index``'s row from its ``proposal``."""
        self.centres[index], self.log_etas[index], self.accepted[index] = (
            proposal.centre,
            proposal.log_eta,
            proposal.accepted,
        )
        self.means[index], self.covariances[index] = proposal.mean, proposal.covariance


def _bounds(starts: np.ndarray, points: np.ndarray, with_starts: bool = False) -> np.ndarray:
    """Per particle, the box (P, 2, 2) (lower and upper corner, world, m) of ``points`` (N, 2)
    (robot frame) placed at each of its ``starts`` (P, K, 3), and of the starts' own positions with
    ``with_starts`` (``mazeslam.gridslam.kernels.bounds``)."""
    from mazeslam.gridslam import kernels  # here, not at the top: numba loads only where the grid filter runs

    return kernels.bounds(
        np.ascontiguousarray(starts, dtype=float), np.ascontiguousarray(points, dtype=float), with_starts
    )


@dataclass(frozen=True)
class ScanSensor:
    """How a log's scans are turned into points: bearings (N,) rad and sensor mount (2,), robot
    frame; max_range, the sensor's maximum range (m, 0 unknown), how far a beam with no return
    clears the map (``GridParams.clear_no_return``, ``scan_rays``)."""

    bearings: np.ndarray
    mount: np.ndarray
    max_range: float = 0.0

    @classmethod
    def of(cls, geometry: BeamGeometry, beams: int, max_range: float = 0.0) -> ScanSensor:
        return cls(geometry.bearings(beams), np.array([geometry.mount_x, geometry.mount_y]), max_range)


class GridSlam:
    """The particle cloud: poses (P, 3) world frame, log weights (P,), each particle's map (``pool``,
    a ``TilePool``: tiles shared copy-on-write) and each path's summed log likelihood (P,)
    (``best_particle``)."""

    def __init__(self, params: GridSlamParams, start_pose, sensor: ScanSensor):
        self.params, self.sensor = params, sensor
        self.search_every_scan = params.search == SearchMode.EVERY_SCAN
        count = params.particles
        self.poses = np.tile(np.asarray(start_pose, dtype=float), (count, 1))
        self.log_weights = np.zeros(count)
        self.log_likelihoods = np.zeros(count)
        self.pool = TilePool(params.grid, count)
        self.rng = np.random.default_rng(params.seed)
        self.resamplings = 0
        self.memo = DistanceMemo()  # the likelihood fields' buffers of the particle-by-particle matches
        self.stencil = STENCIL * np.asarray(params.kernel_step, dtype=float)  # (27, 3) steps around the match
        self.reach = field_reach(params.match, params.grid.resolution)  # cells: where the field's searches end

    @property
    def weights(self) -> np.ndarray:
        return normalized_weights(self.log_weights)

    def best_particle(self) -> int:
        """The particle whose path explains the scans best: the highest ``log_likelihoods``, the
        sum of its and its ancestors' untempered ``log eta`` over the whole run (gmapping's
        ``weightSum``). The weights alone restart at every resampling, so they cannot tell."""
        return int(np.argmax(self.log_likelihoods))

    def map_of(self, particle: int) -> TiledGrid:
        """Particle ``particle``'s map (a copy)."""
        return self.pool.grid(particle)

    def held_bytes(self) -> int:
        """Bytes of cells all particles' maps hold together, shared tiles counted once."""
        return self.pool.held_bytes()

    def process(self, ranges: np.ndarray, motion: np.ndarray) -> ScanUpdate:
        """Move every particle by ``motion`` (3,) (robot frame, since the last processed scan) with
        the improved proposal, weigh it, add the scan (``ranges`` (N,) m) to its map and resample
        if needed."""
        clears_to = self.sensor.max_range if self.params.grid.clear_no_return else 0.0
        rays = scan_rays(ranges, self.sensor.bearings, self.sensor.mount, self.params.grid, clears_to)
        trusted = np.where(ranges >= self.params.grid.min_range, ranges, 0.0)
        points = np.ascontiguousarray(match_points(trusted, self.sensor.bearings, self.sensor.mount, self.params.match))
        covariance = self.params.motion_covariance(motion)
        information = np.linalg.inv(covariance)
        offsets = self._searched_offsets(points, motion, rays) if self.search_every_scan else np.zeros((0, 3))
        count = len(self.poses)
        predicted = compose(self.poses, motion)  # (P, 3)
        _check_finite(predicted, np.zeros(count), motion)
        normals = self.rng.standard_normal((count, 3))  # each particle's draw, in particle order
        starts = compose(predicted[:, None], np.vstack([np.zeros(3), offsets])[None])  # (P, 1 + C, 3)
        reach = _bounds(starts, rays.reach, with_starts=True)  # (P, 2, 2) what the scan updates
        seen = _bounds(starts, points) if len(points) >= 3 else None  # (P, 2, 2) where it is matched
        windows = tile_range(reach, self.params.window_margin, self.pool.tile_metres)  # (P, 2) each: tiles
        self.pool.cover(windows[0].min(axis=0), windows[1].max(axis=0))
        mapped = self.pool.mapped()  # (P,) before this scan
        # 1. each particle's proposal against its own map
        proposals = self._proposals(points, predicted, information, starts, windows, seen, mapped)
        # 2. the draws, all at once
        self.poses = self._drawn(proposals, mapped, motion, covariance, normals)
        nis = np.where(proposals.accepted, motion_nis(self.poses, predicted, covariance), np.nan)
        # 3. each particle's scan into its own map
        self.pool.integrate(rays, self.poses, *windows)
        _check_finite(self.poses, proposals.log_etas, motion)
        weights = self.weights
        log_etas = proposals.log_etas
        self.log_likelihoods += log_etas - log_etas.max()
        self.log_weights += (log_etas - log_etas.max()) / (self.params.observation_gain * count)
        return ScanUpdate(
            proposals.accepted.mean(),
            _weighted_nis(nis, weights),
            effective_sample_size(self.weights),
            self._resample_if_needed(),
        )

    def _proposals(
        self,
        points: np.ndarray,
        predicted: np.ndarray,
        information: np.ndarray,
        starts: np.ndarray,
        windows: tuple[np.ndarray, np.ndarray],
        seen: np.ndarray | None,
        mapped: np.ndarray,
    ) -> Proposals:
        """Every particle's proposal (``_propose``) over its map's cells around ``seen`` (P, 2, 2),
        the box of its end points (None: under 3 points), within its window ``windows`` (tiles,
        lower and upper (P, 2)). ``starts`` (P, 1 + C, 3): its prediction and the refinements'
        other starts (``_searched_offsets``); ``mapped`` (P,): it has a map. Without the search at
        every scan the matches and stencils run for all particles in one compiled call
        (``mazeslam.gridslam.kernels.match_all``), and only the particles whose match failed are
        rescued one by one."""
        proposals = Proposals.empty(predicted)
        if seen is None:
            return proposals
        lowers, uppers = windows
        low, high = crop_cells(
            seen,
            self.params.window_margin,
            lowers * self.pool.tile_metres,  # the windows' origins, as TilePool.window places them
            (uppers - lowers) * self.params.grid.tile_size,
            self.params.grid.resolution,
        )
        if self.search_every_scan:
            one_by_one = np.flatnonzero(mapped)
        else:
            one_by_one = self._match_all(proposals, points, predicted, information, windows, (low, high), mapped)
        for index in one_by_one.tolist():
            window = self.pool.cells(index, lowers[index], low[index], high[index])
            field = LikelihoodField(window, self.params.match, self.memo)
            if field.has_occupied:
                seeds = starts[index] if self.search_every_scan else None
                proposals.set(index, self._propose(field, points, predicted[index], information, seeds))
        return proposals

    def _match_all(
        self,
        proposals: Proposals,
        points: np.ndarray,
        predicted: np.ndarray,
        information: np.ndarray,
        windows: tuple[np.ndarray, np.ndarray],
        crops: tuple[np.ndarray, np.ndarray],
        mapped: np.ndarray,
    ) -> np.ndarray:
        """Every particle's match and, where accepted, its proposal's moments into ``proposals``, in
        one compiled call (``kernels.match_all``) over the cells ``crops`` (low, high (P, 2)) of its
        ``windows`` (tiles, lower and upper (P, 2)). Returns the particles whose match failed (P',):
        ``_propose`` rescues them."""
        from mazeslam.gridslam import kernels  # here, not at the top: numba loads only where the grid filter runs

        first, end, origins = self.pool.crops(windows[0], *crops)
        match = self.params.match
        status, modes, log_etas, means, covariances = kernels.match_all(
            self.pool.tiles,
            self.pool.table,
            self.pool.lower,
            self.params.grid.tile_size,
            float(self.params.grid.resolution),
            mapped,
            first,
            end,
            origins,
            points,
            predicted,
            information,
            kernel_settings(match),
            match.overlap_distance,
            match.min_overlap,
            self.stencil,
            match.sigma,
            match.scale,
            match.floor,
            float(match.occupied_threshold),
            self.reach,
        )
        accepted = status == kernels.ACCEPTED
        proposals.accepted[:] = accepted
        proposals.centres[accepted] = modes[accepted]
        proposals.log_etas[accepted] = log_etas[accepted]
        proposals.means[accepted], proposals.covariances[accepted] = means[accepted], covariances[accepted]
        return np.flatnonzero(status == kernels.FAILED)

    def _drawn(
        self, proposals: Proposals, mapped: np.ndarray, motion: np.ndarray, covariance: np.ndarray, normals: np.ndarray
    ) -> np.ndarray:
        """The new poses (P, 3), drawn with the standard normals ``normals`` (P, 3): from its
        proposal for a particle whose match was accepted, else by the motion model with
        ``covariance`` (3, 3), or, for a particle with no map yet (``mapped`` (P,) False), with
        ``_first_motion_covariance``."""
        accepted = proposals.accepted
        covariances = np.where(accepted[:, None, None], proposals.covariances, covariance)
        covariances[~mapped] = self._first_motion_covariance(motion)
        means = np.where(accepted[:, None], proposals.means, 0.0)
        noise = gaussian(means, covariances, normals)
        drawn = proposals.centres + noise
        drawn[:, 2] = wrap_angle(drawn[:, 2])
        moved = compose(self.poses, motion + noise)  # where the match failed: the motion model
        return np.where(accepted[:, None], drawn, moved)

    def _first_motion_covariance(self, motion: np.ndarray) -> np.ndarray:
        """The noise (3, 3) a particle with no map yet moves by ``motion`` (3,) with: the motion
        noise alone, without ``motion_floor``. The floor stands for the laser odometry's errors
        between scans; the motion to the first scan is odometry from the known start pose (none
        when the first record is a scan), and a floor there would turn each particle's whole map by
        its draw. Drawn at all, not taken as it is, because the map's frame inherits that motion's
        error: on the simulated building the first 0.5 m (0.01 rad off) taken without noise left
        the mean path's pose NEES at 17-40 (3 is consistent)."""
        return self.params.motion_noise.relative_covariance(motion)

    def _propose(
        self,
        field: LikelihoodField,
        points: np.ndarray,
        predicted: np.ndarray,
        information: np.ndarray,
        seeds: np.ndarray | None = None,
    ) -> Proposal:
        """The improved proposal of one particle predicted at ``predicted`` (3,), its scan's end
        points ``points`` (N, 2) robot frame. ``seeds`` (C, 3): where the refinements start when the
        particles search at every scan (the prediction and the scan's searched poses moved onto
        it, ``_searched_offsets``)."""
        match = self.params.match
        if seeds is not None:
            wide = np.linalg.inv(self.params.every_scan_covariance)
            mode = self._best_refinement(field, points, predicted, wide, seeds)
            share = field.overlap(mode, points, match)
        else:
            mode, share = match_pose(field, points, predicted, information, match)
            if share < match.min_overlap:
                mode = self._rescue(field, points, predicted, self.params.rescue_covariance)
                share = field.overlap(mode, points, match)
        accepted = share >= match.min_overlap
        centre = mode if accepted else predicted
        log_eta, mean, covariance = field.kernels.proposal(
            field.kernel_field,
            points,
            centre,
            predicted,
            information,
            self.stencil,
            match.sigma,
            match.scale,
            match.floor,
        )
        return Proposal(centre, log_eta, accepted, mean, covariance)

    def _rescue(
        self, field: LikelihoodField, points: np.ndarray, predicted: np.ndarray, covariance: np.ndarray
    ) -> np.ndarray:
        """The best pose (3,) of the refinements seeded by ``predicted`` (3,) and by a correlative
        search around it over the particle's occupied cells, by likelihood times the prior
        ``N(predicted, covariance)`` (3, 3) that also sets the search's window."""
        seeds = np.vstack([predicted, self._search(field, points, predicted, covariance)])
        return self._best_refinement(field, points, predicted, np.linalg.inv(covariance), seeds)

    def _search(
        self, field: LikelihoodField, points: np.ndarray, predicted: np.ndarray, covariance: np.ndarray
    ) -> np.ndarray:
        """The correlative search's best poses (C, 3) for ``points`` (N, 2) (robot frame) over
        ``field``'s occupied cells, in the window and under the prior ``N(predicted, covariance)``."""
        search = self.params.rescue
        return correlative_candidates(
            LikelihoodGrid(field.occupied_points(), search), points, predicted, covariance, search
        )

    def _best_refinement(
        self,
        field: LikelihoodField,
        points: np.ndarray,
        predicted: np.ndarray,
        information: np.ndarray,
        seeds: np.ndarray,
    ) -> np.ndarray:
        """The best pose (3,) of the refinements from ``seeds`` (C, 3), by likelihood times the
        prior ``N(predicted, information^-1)`` (information (3, 3))."""
        refined = np.array(
            [refine_pose(field, points, predicted, information, self.params.match, seed) for seed in seeds]
        )
        return refined[np.argmax(field.objective(refined, points, predicted, information, self.params.match))]

    def _searched_offsets(self, points: np.ndarray, motion: np.ndarray, rays: ScanRays) -> np.ndarray:
        """The search at every scan, run once: the correlative search's candidates (C, 3) for the
        scan's ``points`` over the best particle's map, around its pose moved by ``motion`` (window
        ``every_scan_sigma``), as poses relative to that prediction. Every particle refines from
        them, moved onto its own prediction, against its own map: the particles' maps share most
        tiles, and one search a scan costs a small part of one per particle. The map is read as far
        as the scan reaches around the prediction in any direction (a turned candidate's points lie
        there)."""
        best = self.best_particle()
        predicted = compose(self.poses[best], motion)
        if not self.pool.mapped()[best] or len(points) < 3:
            return np.zeros((0, 3))
        radius = np.hypot(*rays.reach.T).max(initial=0.0)
        disc = predicted[:2] + np.array([[-radius, -radius], [radius, radius]])
        window = self.pool.window(best, *tile_range(disc, self.params.window_margin, self.pool.tile_metres))
        field = LikelihoodField(window, self.params.match, self.memo)
        if not field.has_occupied:
            return np.zeros((0, 3))
        candidates = self._search(field, points, predicted, self.params.every_scan_covariance)
        return relative(predicted, candidates).reshape(-1, 3)

    def _resample_if_needed(self) -> np.ndarray | None:
        """Systematic resampling when the effective sample size is low: the kept indexes, or None."""
        weights = self.weights
        if effective_sample_size(weights) >= self.params.resample_threshold * len(weights):
            return None
        indexes = systematic_resample(weights, self.rng)
        self.poses = self.poses[indexes]
        self.log_likelihoods = self.log_likelihoods[indexes]
        self._keep_maps(indexes)
        self.log_weights = np.zeros(len(indexes))
        self.resamplings += 1
        return indexes

    def _keep_maps(self, indexes: np.ndarray) -> None:
        """The maps of the particles ``indexes`` (P,) kept by a resampling, in that order."""
        self.pool.resample(indexes)

    def cloud(self, pending: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The particles moved on by ``pending`` (3,), the motion not processed yet: poses (P, 3),
        their weighted mean (3,) and covariance (3, 3) (headings around the mean's)."""
        poses = compose(self.poses, pending)
        weights = self.weights
        heading = np.angle(weights @ np.exp(1j * poses[:, 2]))
        deviation = poses - np.r_[weights @ poses[:, :2], heading]
        deviation[:, 2] = wrap_angle(deviation[:, 2])
        mean = np.r_[weights @ poses[:, :2], heading]
        return poses, mean, (deviation * weights[:, None]).T @ deviation


@dataclass(kw_only=True)
class GridSlamResult:
    """A grid filter run over a log.

    Attributes:
        scan_records: (S,) record numbers of the log's scans; times (S,) their times, s.
        best_poses: (S, 3) the path of the final best particle at every scan (consistent with
            ``grid``); mean_poses (S, 3) the cloud's weighted mean after each scan and covariances
            (S, 3, 3) its spread. World frame, m and rad.
        processed: (S,) the scan was matched and mapped (else the robot had not moved enough).
        matched: (S,) share of the particles whose match was accepted (NaN where not processed).
        nis: (S,) the motion's NIS (``ScanUpdate.nis``; NaN where not processed or not matched).
        neff: (S,) effective sample size after the scan's weighting, before any resampling.
        resampled: (S,) the particles were resampled after the scan.
        grid: the final best particle's map.
        seconds: (S,) wall-clock seconds of each scan; motion_seconds the laser odometry's.
        peak_map_bytes: the most bytes of cells all particles' maps held together after a scan
            (shared tiles counted once).
        particles: the final cloud (for inspection).
        reckoned: (R, 3) the odometry the filter moved by, from ``reckoned_start`` (3,), at every
            record's time (``odometry_at_record_times``): what carries a scan's pose on to the
            records after it.
        snapshots: the frames kept for ``--animate`` (``mazeslam.gridslam.snapshots.GridSnapshot``).
    """

    scan_records: np.ndarray
    times: np.ndarray
    best_poses: np.ndarray
    mean_poses: np.ndarray
    covariances: np.ndarray
    processed: np.ndarray
    matched: np.ndarray
    nis: np.ndarray
    neff: np.ndarray
    resampled: np.ndarray
    grid: TiledGrid
    seconds: np.ndarray
    motion_seconds: float
    peak_map_bytes: int
    particles: GridSlam
    reckoned: np.ndarray
    reckoned_start: np.ndarray
    snapshots: list = field(default_factory=list)

    @property
    def resamplings(self) -> int:
        return int(self.resampled.sum())

    @property
    def total_seconds(self) -> float:
        return float(self.seconds.sum() + self.motion_seconds)

    def record_trajectory(self, which: str = "best") -> tuple[np.ndarray, np.ndarray]:
        """Poses (R, 3) and covariances (R, 3, 3) at every record of the log, as
        ``sidecars.write_trajectory`` takes them (``carried_to_records``). ``which``: "best" or "mean"."""
        scan_poses = {"best": self.best_poses, "mean": self.mean_poses}[which]
        return carried_to_records(self.scan_records, scan_poses, self.covariances, self.reckoned, self.reckoned_start)


def odometry_at_record_times(course_log: CourseLog, start_pose) -> np.ndarray:
    """The pose (R, 3) at every record's own time by the odometry, world frame.

    An odometry record's pose is the odometry integrated up to it. Any other record (a scan) falls
    between two odometry records: it gets the earlier one's pose advanced by the share of the later
    one's motion its time says, ``(t - t_before) / (t_after - t_before)`` (none before the first or
    after the last odometry record). The course robot's logger takes a scan 0.2-0.3 s after the
    odometry record before it: turning at 0.26 rad/s, that is 3-4 deg a scan, which, put into the
    map with the scan, turns the map a little at every scan of a turn."""
    poses = dead_reckoning(course_log, start_pose)
    odometry = np.flatnonzero(course_log.is_odometry)
    others = np.flatnonzero(~course_log.is_odometry)
    after = np.searchsorted(odometry, others)
    inside = (after > 0) & (after < len(odometry))
    others, after = others[inside], odometry[after[inside]]
    before = odometry[np.searchsorted(odometry, others) - 1]
    times = course_log.times
    share = np.clip((times[others] - times[before]) / np.maximum(times[after] - times[before], 1e-9), 0.0, 1.0)
    distance, turn = course_log.values[after, 0], course_log.values[after, 1]
    poses[others] = advance_pose(poses[before], share * distance, share * turn)
    return poses


def scan_motions(course_log: CourseLog, geometry: BeamGeometry, params: GridSlamParams, start_pose) -> np.ndarray:
    """The motion (S, 3) before each scan (robot frame of the previous scan; the first from the
    start pose): the laser odometry's, or the odometry between the scans' times
    (``odometry_at_record_times``; ``params.motion``)."""
    if params.motion == MotionSource.LASER:
        return laser_odometry(course_log, geometry, params.laser_odometry).increments
    at_scans = odometry_at_record_times(course_log, start_pose)[course_log.is_scan]
    start = np.asarray(start_pose, dtype=float)[None]
    return relative(np.vstack([start, at_scans[:-1]]), at_scans).reshape(-1, 3)


def run_grid_slam(
    course_log: CourseLog,
    geometry: BeamGeometry,
    start_pose,
    params: GridSlamParams | None = None,
    progress: bool = False,
    snapshot_every: int = 0,
    sensor_max_range: float = 0.0,
    on_scan=None,
) -> GridSlamResult:
    """The grid filter over every scan of ``course_log`` (see the module docstring). With
    ``snapshot_every`` > 0, every that many scans (and at the last) the best particle's map and the
    particles are kept for ``--animate`` (``GridSlamResult.snapshots``). ``sensor_max_range``: the
    laser's maximum range (m), up to which a beam with no return clears the map with
    ``params.grid.clear_no_return`` (0: unknown, such beams are left out). ``on_scan(record_index,
    filter)``, when given, is called after every scan with the ``GridSlam`` (for a live view:
    ``mazeslam.viz.live``); it must not change the filter."""
    params = params or GridSlamParams()
    began = time.perf_counter()
    motions = scan_motions(course_log, geometry, params, start_pose)
    motion_seconds = time.perf_counter() - began
    records = np.flatnonzero(course_log.is_scan)
    count, particles = len(records), params.particles
    sensor = ScanSensor.of(geometry, course_log.width, sensor_max_range)
    slam = GridSlam(params, start_pose, sensor)
    node_poses, node_parents = np.empty((count, particles, 3)), np.empty((count, particles), dtype=int)
    mean_poses, covariances = np.empty((count, 3)), np.empty((count, 3, 3))
    processed, resampled = np.zeros(count, bool), np.zeros(count, bool)
    matched, nis, neff = np.full(count, np.nan), np.full(count, np.nan), np.full(count, float(particles))
    seconds = np.empty(count)
    pending, peak_map_bytes, snapshots = np.zeros(3), 0, []
    from tqdm.auto import tqdm  # here: the slam config names the grid's settings, and tqdm is slow to load

    for index in tqdm(range(count), desc="grid SLAM", unit="scan", disable=not progress):
        started = time.perf_counter()
        pending = compose(pending, motions[index])
        parents = np.arange(particles)
        if index == 0 or np.hypot(*pending[:2]) >= params.linear_update or abs(pending[2]) >= params.angular_update:
            try:
                update = slam.process(course_log.values[records[index]], pending)
            except GridDivergence as error:
                raise GridDivergence(f"{course_log.line_of(records[index])}: {error}") from None
            matched[index], nis[index], neff[index] = update.matched, update.nis, update.neff
            processed[index], pending = True, np.zeros(3)
            peak_map_bytes = max(peak_map_bytes, slam.held_bytes())
            if update.indexes is not None:
                parents, resampled[index] = update.indexes, True
        node_poses[index], mean_poses[index], covariances[index] = slam.cloud(pending)
        node_parents[index] = parents
        seconds[index] = time.perf_counter() - started
        if snapshot_every and (index % snapshot_every == 0 or index == count - 1):
            from mazeslam.gridslam.snapshots import snapshot

            snapshots.append(snapshot(index, slam.map_of(slam.best_particle()), node_poses[index]))
        if on_scan is not None:
            on_scan(int(records[index]), slam)
    best = slam.best_particle()
    return GridSlamResult(
        scan_records=records,
        times=course_log.times[records],
        best_poses=_backtrack(node_poses, node_parents, best),
        mean_poses=mean_poses,
        covariances=covariances,
        processed=processed,
        matched=matched,
        nis=nis,
        neff=neff,
        resampled=resampled,
        grid=slam.map_of(best),
        seconds=seconds,
        motion_seconds=motion_seconds,
        peak_map_bytes=peak_map_bytes,
        particles=slam,
        reckoned=odometry_at_record_times(course_log, start_pose),
        reckoned_start=np.asarray(start_pose, dtype=float),
        snapshots=snapshots,
    )


def _backtrack(node_poses: np.ndarray, node_parents: np.ndarray, particle: int) -> np.ndarray:
    """The path (S, 3) of ``particle`` through the ancestry: ``node_poses`` (S, P, 3) holds every
    particle's pose at each scan, ``node_parents`` (S, P) the index at the scan before of its ancestor."""
    path = np.empty((len(node_poses), 3))
    for index in range(len(node_poses) - 1, -1, -1):
        path[index] = node_poses[index, particle]
        particle = node_parents[index, particle]
    return path
