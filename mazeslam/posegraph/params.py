"""The pose graph's settings (TOML section ``[posegraph]`` of a slam config, with ``[posegraph.sequential]``,
``[posegraph.closures]`` and ``[posegraph.solve]``): plain dataclasses, so that a config loads
without the solver's libraries. What each setting does is in the module that uses it:
``mazeslam.posegraph.sequential``, ``.closures``, ``.solve`` and ``.laser_graph``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from mazeslam.core.config import require
from mazeslam.registration.correlative import CorrelativeParams


@dataclass(frozen=True)
class SequentialParams:
    """How the laser odometry's intervals become edges.

    Attributes:
        variance_scale: the match covariance's inflation over the independent-beam one. 8: measured
            with ``experiments/carmen_posegraph/match_noise.py`` on the 7 CARMEN logs with odometry
            (the factor that brings the median NEES of the intervals' errors against the reference
            increments to chi-square's median for 3 degrees of freedom, 2.37: 1.1 to 16 by log,
            median 8.1; results/match_noise.md).
        floor: standard deviation (m and rad) added to every axis: the laser odometry prior's
            floor (``ScanMatchParams.prior_floor``, 0.01), a robot that seems still may have moved.
    """

    variance_scale: float = 8.0
    floor: float = 0.01

    def __post_init__(self):
        require(self.variance_scale > 0, f"variance_scale must be positive, got {self.variance_scale}")
        require(self.floor > 0, f"floor must be positive (m, rad), got {self.floor}")


@dataclass(frozen=True)
class ClosureParams:
    """Which scans are matched to which submaps, and when a match is accepted.

    Attributes:
        keyframe_distance, keyframe_turn: a keyframe after this much travel (m) or turning (rad):
            the grid filter's ``linear_update`` and ``angular_update`` (0.5, 0.25).
        local_anchors: match each keyframe against the keyframes this many before it and this
            many after it: (2, 4, 8, 16), about 1, 2, 4 and 8 m at the keyframe spacing, the
            stretch of the map behind it that a scan-to-map matcher (the grid filter's) would
            match it to, and the same stretch ahead, which only a smoother has; the nearest skips
            the neighbour the sequential edge already ties it to. Empty: no local edges.
        min_loop_path: a closure's anchor is at least this far back along the path, m.
        search_radius: and within this distance of the query by the estimate, m, plus 3 window
            standard deviations; about the laser's useful reach indoors (a room, a corridor's width).
        closures_per_scan: at most this many closures tried from one keyframe (nearest visits first).
        submap_path: the submap holds the keyframes within this path distance of its anchor, m.
        voxel: the submap keeps one point per voxel of this side, m (the grid's 5 cm).
        min_window, max_window: bounds of the search window's standard deviation (m, rad); the
            lower is the laser odometry's prior floor raised to a cell and a turn step, the upper
            keeps a search on one core under 0.1 s.
        correlative: the search's grid and turns (``CorrelativeParams``; 0.1 m cells, 0.1 m spread,
            1.5 degree turns, 5 basins refined).
        min_overlap: the accepted match has at least this share of its points within the last
            correspondence distance of the submap (the laser odometry's 0.5 would let a scan that
            sees half its surroundings anew close a loop; a closure needs to see the same place).
        ambiguity_ratio: the best mode's objective must be at most this times the second best's
            (0.7: the second explains 30 % more of the residual than the best; Olson's test of the
            best against the second best peak).
        mode_distance, mode_turn: refined poses closer than this (m, rad) are the same mode.
        max_sigma: the match's position standard deviation along its worst direction must be at
            most this (m): a corridor fixes nothing along itself.
        window_cells: a wider window is searched on cells (and turn steps) coarser by a power of 2
            (at most 8), so that its standard deviation spans at most this many cells: the search's
            cost stays below (2 x 2.5 x window_cells + 1)^2 shifts per turn.
    """

    keyframe_distance: float = 0.5
    keyframe_turn: float = 0.25
    local_anchors: tuple = (2, 4, 8, 16)
    min_loop_path: float = 8.0
    search_radius: float = 3.0
    closures_per_scan: int = 2
    submap_path: float = 3.0
    voxel: float = 0.05
    min_window: tuple = (0.1, 0.05)
    max_window: tuple = (1.0, 0.35)
    correlative: CorrelativeParams = field(
        default_factory=lambda: CorrelativeParams(resolution=0.1, sigma=0.1, turn_step=1.5, candidates=5, max_points=90)
    )
    min_overlap: float = 0.6
    ambiguity_ratio: float = 0.7
    mode_distance: float = 0.2
    mode_turn: float = 0.05
    max_sigma: float = 0.15
    window_cells: float = 4.0

    def __post_init__(self):
        object.__setattr__(self, "min_window", tuple(self.min_window))
        object.__setattr__(self, "max_window", tuple(self.max_window))
        object.__setattr__(self, "local_anchors", tuple(self.local_anchors))
        require(all(2 <= back <= 100 for back in self.local_anchors), "local_anchors must be in 2..100")
        require(
            self.keyframe_distance > 0 and self.keyframe_turn > 0,
            "keyframe_distance and keyframe_turn must be positive",
        )
        require(self.min_loop_path > 0 and self.search_radius > 0, "min_loop_path and search_radius must be positive")
        require(1 <= self.closures_per_scan <= 100, "closures_per_scan must be in 1..100")
        require(self.submap_path >= 0 and self.voxel > 0, "submap_path must be >= 0 and voxel positive (m)")
        for name in ("min_window", "max_window"):
            value = getattr(self, name)
            require(len(value) == 2 and all(v > 0 for v in value), f"{name}: 2 positive values (m, rad)")
        require(
            all(low <= high for low, high in zip(self.min_window, self.max_window)),
            "min_window must not exceed max_window",
        )
        require(0 <= self.min_overlap <= 1, "min_overlap must be a fraction")
        require(0 < self.ambiguity_ratio <= 1, "ambiguity_ratio must be in (0, 1]")
        require(self.mode_distance > 0 and self.mode_turn > 0, "mode_distance and mode_turn must be positive")
        require(self.max_sigma > 0, "max_sigma must be positive (m)")
        require(self.window_cells >= 1, "window_cells must be at least 1")


@dataclass(frozen=True)
class SolveParams:
    """Settings of the robust solve.

    Attributes:
        kernel_chi2: Phi, the chi2 (3 degrees of freedom) at which a robust edge's weight falls to
            a quarter and beyond which it is dropped: 11.34, chi-square's 99 % quantile for 3
            degrees of freedom, so that a true edge whose covariance is right is kept 99 times in 100.
        gnc_factor: ``mu`` is divided by this at each step of the graduated non-convexity (1.4, as
            Yang et al. 2020 use).
        gnc_iterations: Levenberg-Marquardt iterations at each ``mu`` above 1.
        max_iterations: iterations at ``mu`` = 1 and in the final Gaussian solve, each.
        step_tolerance: the solve stops once a step moves no pose by more than this (m or rad).
        drift_sigma: the prior standard deviation of the scan matches' heading drift, rad/m (0: not
            estimated, held at 0; ``mazeslam.posegraph.graph``). 0.005: the laser odometry's drift
            against the reference poses is -0.003 to +0.0002 rad/m on the 7 CARMEN logs with
            odometry (experiments/carmen_posegraph/results/match_noise.md), so that the prior admits
            every drift seen and decides nothing where loops do.
    """

    kernel_chi2: float = 11.34
    gnc_factor: float = 1.4
    gnc_iterations: int = 3
    max_iterations: int = 50
    step_tolerance: float = 1e-6
    drift_sigma: float = 0.005

    def __post_init__(self):
        require(self.kernel_chi2 > 0, f"kernel_chi2 must be positive, got {self.kernel_chi2}")
        require(1 < self.gnc_factor <= 100, f"gnc_factor must be in (1, 100], got {self.gnc_factor}")
        require(
            1 <= self.gnc_iterations <= 100 and 1 <= self.max_iterations <= 10_000,
            "gnc_iterations must be in 1..100 and max_iterations in 1..10000",
        )
        require(self.step_tolerance > 0, "step_tolerance must be positive (m, rad)")
        require(self.drift_sigma >= 0, f"drift_sigma must be >= 0 (rad/m; 0: no drift), got {self.drift_sigma}")


@dataclass(frozen=True)
class PoseGraphParams:
    """Settings of the laser log's pose graph.

    Attributes:
        sequential: the laser odometry's edges (``SequentialParams``).
        closures: which local and closure matches are tried and accepted (``ClosureParams``).
        solve: the robust solve (``SolveParams``).
        passes: at most this many rounds of detection and solve.
        grid_start: on a log without wheel odometry, start from the grid filter's best path (the
            slam config's ``[grid]``) instead of the blind laser odometry's chain. On orebro (the
            one CARMEN log without odometry) the blind chain is metres or a right angle wrong at
            about a dozen corridor steps, and matches searched around it agree with it or are
            refused: aligned ATE 7.1 m from the chain, 0.35 m from the grid path (the grid path
            alone: 0.55 m; experiments/carmen_posegraph/README.md).
    """

    sequential: SequentialParams = field(default_factory=SequentialParams)
    closures: ClosureParams = field(default_factory=ClosureParams)
    solve: SolveParams = field(default_factory=SolveParams)
    passes: int = 3
    grid_start: bool = True

    def __post_init__(self):
        require(1 <= self.passes <= 100, f"passes must be in 1..100, got {self.passes}")
