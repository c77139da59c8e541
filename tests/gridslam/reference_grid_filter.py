"""The grid filter as it was written before its compiled kernels: a Python loop over particles,
numpy for the scan match and the ray integration, and OpenCV's distance transform of the map around
each scan for the likelihood field. The oracle the compiled filter is checked against
(tests/gridslam/test_grid_kernels.py) and its speed baseline (benchmarks/bench_grid.py).

``ReferenceGridSlam(params, start_pose, sensor)`` subclasses ``GridSlam`` only to share its poses,
weights, resampling and cloud; its maps are the old ones (a ``TiledGrid`` a particle, not the
filter's tile pool) and its scan update is the old one.
"""

from __future__ import annotations

import numpy as np

from mazeslam.core.geometry import compose, relative, transform_points, wrap_angle
from mazeslam.core.motion import predict_relative
from mazeslam.core.resampling import effective_sample_size
from mazeslam.gridslam.filter import STENCIL, GridSlam, ScanUpdate, _weighted_nis, motion_nis
from mazeslam.gridslam.matching import MatchParams, field_reach, match_points
from mazeslam.gridslam.occupancy import GridParams, ScanRays, TiledGrid, Window, scan_rays
from mazeslam.registration.correlative import LikelihoodGrid, correlative_candidates


class ReferenceField:
    """The distance (m) from each cell of ``window`` to its nearest occupied cell, clipped at the
    field's reach (``field_reach``), interpolated."""

    def __init__(self, window: Window, params: MatchParams):
        import cv2  # here, not at the top: the slam config names the grid's settings, and OpenCV is slow to load

        self.occupied = window.values > params.occupied_threshold
        free = (~self.occupied).astype(np.uint8)
        self.has_occupied = bool(self.occupied.any())
        transform = cv2.distanceTransform(free, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
        reach = np.float32(field_reach(params, window.resolution))
        self.distance = np.minimum(transform, reach) * window.resolution
        self.origin, self.resolution = window.origin, window.resolution

    def occupied_points(self) -> np.ndarray:
        """World positions (M, 2) of the occupied cells' centres, m."""
        return self.origin + (np.argwhere(self.occupied) + 0.5) * self.resolution

    def lookup(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Bilinear distance (...,) at world ``points`` (..., 2) and its gradient (..., 2), m/m.
        Points outside the window take the nearest border cells."""
        cell = (points - self.origin) / self.resolution - 0.5  # cell centres at integers
        base = np.floor(cell)
        frac = cell - base
        limit = np.array(self.distance.shape) - 2
        i = np.clip(base[..., 0].astype(int), 0, limit[0])
        j = np.clip(base[..., 1].astype(int), 0, limit[1])
        d00, d10 = self.distance[i, j], self.distance[i + 1, j]
        d01, d11 = self.distance[i, j + 1], self.distance[i + 1, j + 1]
        fx, fy = frac[..., 0], frac[..., 1]
        value = (d00 * (1 - fx) + d10 * fx) * (1 - fy) + (d01 * (1 - fx) + d11 * fx) * fy
        gradient_x = ((d10 - d00) * (1 - fy) + (d11 - d01) * fy) / self.resolution
        gradient_y = ((d01 - d00) * (1 - fx) + (d11 - d10) * fx) / self.resolution
        return value, np.stack([gradient_x, gradient_y], axis=-1)

    def log_likelihood(self, poses: np.ndarray, points: np.ndarray, params: MatchParams) -> np.ndarray:
        """``log p(z | m, x)`` (K,) of end points ``points`` (N, 2) (robot frame) at ``poses`` (K, 3)."""
        cos_t, sin_t = np.cos(poses[:, 2:3]), np.sin(poses[:, 2:3])
        world = np.stack(
            [
                poses[:, :1] + cos_t * points[:, 0] - sin_t * points[:, 1],
                poses[:, 1:2] + sin_t * points[:, 0] + cos_t * points[:, 1],
            ],
            axis=-1,
        )
        distance, _ = self.lookup(world)
        return params.scale * np.log(np.exp(-0.5 * (distance / params.sigma) ** 2) + params.floor).sum(axis=-1)

    def objective(
        self,
        poses: np.ndarray,
        points: np.ndarray,
        prior: np.ndarray,
        prior_information: np.ndarray,
        params: MatchParams,
    ) -> np.ndarray:
        """``log p(z | m, x)`` plus the Gaussian prior's log density (up to a constant) at ``poses`` (K, 3)."""
        offsets = poses - prior
        offsets[:, 2] = wrap_angle(offsets[:, 2])
        penalty = 0.5 * np.einsum("ki,ij,kj->k", offsets, prior_information, offsets)
        return self.log_likelihood(poses, points, params) - penalty

    def overlap(self, pose: np.ndarray, points: np.ndarray, params: MatchParams) -> float:
        """Fraction of ``points`` (N, 2) (robot frame) within ``overlap_distance`` of an occupied cell."""
        distance, _ = self.lookup(transform_points(pose, points))
        return float(np.mean(distance <= params.overlap_distance))


def cells(window: Window, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The window cells (i (K,), j (K,)) of those of world ``points`` (N, 2) inside the window."""
    index = np.floor((points - window.origin) / window.resolution).astype(int)
    inside = np.all((index >= 0) & (index < window.values.shape), axis=1)
    return index[inside, 0], index[inside, 1]


def refine_pose(
    field: ReferenceField,
    points: np.ndarray,
    prior: np.ndarray,
    prior_information: np.ndarray,
    params: MatchParams,
    start: np.ndarray | None = None,
) -> np.ndarray:
    """The pose (3,) maximising the likelihood of ``points`` (N, 2) (robot frame) times the Gaussian
    motion prior (mean ``prior`` (3,), information (3, 3)), from ``start`` (default ``prior``).

    Each stage of ``sigma_schedule`` runs ``iterations`` Gauss-Newton steps on the residuals
    ``d_i`` weighted by ``rho'(d_i) / d_i`` of ``rho(d) = -log(exp(-d^2 / (2 s^2)) + floor)``: points
    near a wall weigh ``1 / s^2``, points far from all walls nothing.
    """
    pose = np.array(prior if start is None else start, dtype=float)
    for sigma in params.sigma_schedule:
        for _ in range(params.iterations):
            cos_t, sin_t = np.cos(pose[2]), np.sin(pose[2])
            arm = np.column_stack(
                [cos_t * points[:, 0] - sin_t * points[:, 1], sin_t * points[:, 0] + cos_t * points[:, 1]]
            )
            distance, gradient = field.lookup(pose[:2] + arm)
            jacobian = np.column_stack([gradient, gradient[:, 1] * arm[:, 0] - gradient[:, 0] * arm[:, 1]])
            likelihood = np.exp(-0.5 * (distance / sigma) ** 2)
            weight = params.scale * likelihood / (likelihood + params.floor) / sigma**2
            offset = pose - prior
            offset[2] = wrap_angle(offset[2])
            hessian = (jacobian * weight[:, None]).T @ jacobian + prior_information
            step = np.linalg.solve(hessian, (jacobian * weight[:, None]).T @ distance + prior_information @ offset)
            pose -= step
            pose[2] = wrap_angle(pose[2])
    return pose


def integrate_scan(window: Window, rays: ScanRays, pose: np.ndarray, params: GridParams) -> np.ndarray:
    """Add one scan taken at robot ``pose`` (3,) to ``window`` in place: each cell a beam crosses
    gets ``miss`` once, each cell a beam ends in ``hit`` once (and no miss), clamped. Returns the
    tiles changed, as ``TiledGrid.store`` takes them. Samples outside the window are left out."""
    free = np.zeros(window.values.shape, dtype=bool)
    hits = np.zeros(window.values.shape, dtype=bool)
    free[cells(window, transform_points(pose, rays.free))] = True
    hits[cells(window, transform_points(pose, rays.hits))] = True
    free &= ~hits
    window.values[free] += params.miss
    window.values[hits] += params.hit
    np.clip(window.values, -params.clamp, params.clamp, out=window.values)
    changed = free | hits
    size = params.tile_size
    return changed.reshape(changed.shape[0] // size, size, changed.shape[1] // size, size).any(axis=(1, 3))


class ReferenceGridSlam(GridSlam):
    """The grid filter's scan update as a Python loop over particles (see the module docstring)."""

    def __init__(self, params, start_pose, sensor):
        super().__init__(params, start_pose, sensor)
        self.maps = [TiledGrid(params.grid) for _ in range(params.particles)]

    def map_of(self, particle: int) -> TiledGrid:
        return self.maps[particle]

    def held_bytes(self) -> int:
        """Bytes of cells all particles' maps hold together, each shared tile counted once."""
        distinct = set().union(*(map(id, grid.tiles.values()) for grid in self.maps))
        return len(distinct) * self.params.grid.tile_size**2 * np.dtype(np.float32).itemsize

    def _keep_maps(self, indexes: np.ndarray) -> None:
        self.maps = [self.maps[index].copy() for index in indexes]

    def process(self, ranges: np.ndarray, motion: np.ndarray) -> ScanUpdate:
        """Move every particle by ``motion`` (3,) (robot frame, since the last processed scan) with
        the improved proposal, weigh it, add the scan (``ranges`` (N,) m) to its map and resample
        if needed."""
        clears_to = self.sensor.max_range if self.params.grid.clear_no_return else 0.0
        rays = scan_rays(ranges, self.sensor.bearings, self.sensor.mount, self.params.grid, clears_to)
        trusted = np.where(ranges >= self.params.grid.min_range, ranges, 0.0)
        points = match_points(trusted, self.sensor.bearings, self.sensor.mount, self.params.match)
        covariance = self.params.motion_covariance(motion)
        information = np.linalg.inv(covariance)
        offsets = self._searched_offsets(points, motion, rays) if self.search_every_scan else np.zeros((0, 3))
        log_etas, nis, matched = np.zeros(len(self.poses)), np.full(len(self.poses), np.nan), 0
        weights = self.weights
        for index, grid in enumerate(self.maps):
            predicted = compose(self.poses[index], motion)
            starts = np.vstack([predicted, compose(predicted, offsets).reshape(-1, 3)])  # (1 + C, 3)
            reach = np.vstack([transform_points(start, rays.reach) for start in starts] + [starts[:, :2]])
            window = grid.window(*grid.tile_range(reach, self.params.window_margin))
            if grid.tiles and len(points) >= 3:
                seen = np.vstack([transform_points(start, points) for start in starts])
                field = ReferenceField(window.crop(seen, self.params.window_margin), self.params.match)
                if field.has_occupied:
                    pose, log_etas[index], accepted = self._propose(
                        field, points, predicted, information, starts if self.search_every_scan else None
                    )
                    if accepted:
                        nis[index] = motion_nis(pose, predicted, covariance)
                    else:
                        pose = self._unmatched_draw(index, motion, covariance)
                    matched += accepted
                    self.poses[index] = pose
                else:
                    self.poses[index] = self._unmatched_draw(index, motion, covariance)
            else:
                self.poses[index] = self._unmatched_draw(index, motion, covariance)
            grid.store(window, integrate_scan(window, rays, self.poses[index], self.params.grid))
        self.log_likelihoods += log_etas - log_etas.max()
        self.log_weights += (log_etas - log_etas.max()) / (self.params.observation_gain * len(self.poses))
        return ScanUpdate(
            matched / len(self.poses),
            _weighted_nis(nis, weights),
            effective_sample_size(self.weights),
            self._resample_if_needed(),
        )

    def _unmatched_draw(self, index: int, motion: np.ndarray, covariance: np.ndarray) -> np.ndarray:
        """The pose (3,) of particle ``index`` moved by ``motion`` (3,) with noise where its match failed
        or nothing of its map lies near the scan: ``covariance`` (3, 3), or, before its first scan, the motion noise
        alone, without ``motion_floor``. The floor stands for the laser odometry's errors between
        scans; the motion to the first scan is odometry from the known start pose (none when the
        first record is a scan), and a floor there would turn each particle's whole map by its
        draw. Drawn at all, not taken as it is, because the map's frame inherits that motion's
        error: on the simulated building the first 0.5 m (0.01 rad off) taken without noise left
        the mean path's pose NEES at 17-40 (3 is consistent)."""
        if not self.maps[index].tiles:
            covariance = self.params.motion_noise.relative_covariance(motion)
        return predict_relative(self.poses[index][None], motion, covariance, self.rng)[0]

    def _propose(
        self,
        field: ReferenceField,
        points: np.ndarray,
        predicted: np.ndarray,
        information: np.ndarray,
        seeds: np.ndarray | None = None,
    ) -> tuple[np.ndarray, float, bool]:
        """The improved proposal of one particle: the drawn pose (3,), ``log eta`` and whether the
        match was accepted (if not, the pose is the stencil's centre and the caller draws one).
        ``seeds`` (C, 3): where the refinements start when the particles search at every scan (the
        prediction and the scan's searched poses moved onto it, ``_searched_offsets``)."""
        match = self.params.match
        if seeds is not None:
            wide = np.linalg.inv(self.params.every_scan_covariance)
            mode = self._best_refinement(field, points, predicted, wide, seeds)
        else:
            mode = refine_pose(field, points, predicted, information, match)
            if field.overlap(mode, points, match) < match.min_overlap:
                mode = self._rescue(field, points, predicted, self.params.rescue_covariance)
        accepted = field.overlap(mode, points, match) >= match.min_overlap
        centre = mode if accepted else predicted
        stencil = centre + STENCIL * self.params.kernel_step
        log_tau = field.objective(stencil, points, predicted, information, match)
        log_eta = float(log_tau.max() + np.log(np.exp(log_tau - log_tau.max()).sum()))
        if not accepted:
            return centre, log_eta, False
        weights = np.exp(log_tau - log_eta)
        spread = STENCIL * self.params.kernel_step
        mean = weights @ spread
        covariance = (spread - mean).T @ ((spread - mean) * weights[:, None]) + 1e-10 * np.eye(3)
        pose = centre + self.rng.multivariate_normal(mean, covariance, method="eigh")
        pose[2] = wrap_angle(pose[2])
        return pose, log_eta, True

    def _rescue(
        self, field: ReferenceField, points: np.ndarray, predicted: np.ndarray, covariance: np.ndarray
    ) -> np.ndarray:
        """The best pose (3,) of the refinements seeded by ``predicted`` (3,) and by a correlative
        search around it over the particle's occupied cells, by likelihood times the prior
        ``N(predicted, covariance)`` (3, 3) that also sets the search's window."""
        seeds = np.vstack([predicted, self._search(field, points, predicted, covariance)])
        return self._best_refinement(field, points, predicted, np.linalg.inv(covariance), seeds)

    def _search(
        self, field: ReferenceField, points: np.ndarray, predicted: np.ndarray, covariance: np.ndarray
    ) -> np.ndarray:
        """The correlative search's best poses (C, 3) for ``points`` (N, 2) (robot frame) over
        ``field``'s occupied cells, in the window and under the prior ``N(predicted, covariance)``."""
        search = self.params.rescue
        return correlative_candidates(
            LikelihoodGrid(field.occupied_points(), search), points, predicted, covariance, search
        )

    def _best_refinement(
        self,
        field: ReferenceField,
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
        grid, predicted = self.maps[best], compose(self.poses[best], motion)
        if not grid.tiles or len(points) < 3:
            return np.zeros((0, 3))
        radius = np.hypot(*rays.reach.T).max(initial=0.0)
        disc = predicted[:2] + np.array([[-radius, -radius], [radius, radius]])
        field = ReferenceField(grid.window(*grid.tile_range(disc, self.params.window_margin)), self.params.match)
        if not field.has_occupied:
            return np.zeros((0, 3))
        candidates = self._search(field, points, predicted, self.params.every_scan_covariance)
        return relative(predicted, candidates).reshape(-1, 3)
