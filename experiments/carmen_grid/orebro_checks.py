"""Can orebro's scans alone tell where the robot went? Checks of the sensor model and of the
matching against the log's reference poses (orebro has no wheel odometry, and its laser odometry
misses metres along corridors: docs/grid.md, "Known limits").

1. Beam model: the median distance from each scan's end points to the previous scan's nearest end
   point (within 0.5 m), both placed at the reference poses, averaged over the intervals, for
   mounting offsets, beam-angle offsets and beam steps around the importer's (mount 0, first beam
   at -90 deg, 1 deg steps for 181 beams). The reference poses come from a grid-mapping run, so
   the model that run used gives the sharpest overlay.
2. Scan to map: for each scan k, a map drawn from the reference poses of scans 0..k-1; scan k is
   matched against it by the grid filter's matcher after a correlative search over a wide window
   (prior sigma 1 m and 0.3 rad) around the laser odometry's prediction from the reference pose
   k-1. Counted: scans whose best pose is more than 0.3 m or 0.1 rad from the reference, and how
   many of those the objective (likelihood times prior) prefers to the reference pose refined
   (the model prefers the wrong pose) rather than the search missing it. Variants: the 20 m cut of
   mapping and matching and 40 m (orebro's corridor ends are 22-29 m away); an end point in a
   never-observed cell scored as free space (the filter's likelihood field) or as a cell of
   unknown occupancy (likelihood 0.5, the occupancy prior).
3. Scan to scan at the intervals where the laser odometry is wrong: the matcher's objective
   (lower is better) refined from the reference increment and from the laser odometry's.
4. Past and future: at the intervals where the laser odometry is more than 0.3 m or 0.1 rad off
   the reference's increment, scan k placed at its reference pose and at the laser odometry's
   pose (the reference pose k-1 moved by the laser odometry's increment k), against the scans
   k-10..k-1 (what a filter has seen) and k+1..k+3 (what only a smoother sees) at their reference
   poses: the share of its end points within ``NEIGHBOUR_GAP`` of theirs. Where both poses fit as
   well, the scans cannot say which is right. Then the floor that ambiguity sets: the aligned ATE
   of the reference with the laser odometry's pose taken at the scans where the past fits it as
   well as the reference's (within ``TIE``) or better.

Run: ``python -m experiments.carmen_grid.orebro_checks`` (about 10 CPU minutes); writes
``results/orebro_checks.md``.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from experiments.carmen_grid.run import RESULTS, imported_run
from mazeslam.core.geometry import compose, relative, transform_points, wrap_angle
from mazeslam.data.loaded_run import LoadedRun
from mazeslam.evaluation.metrics import absolute_trajectory_error
from mazeslam.gridslam.filter import ScanSensor
from mazeslam.gridslam.matching import LikelihoodField, MatchParams, match_points, refine_pose
from mazeslam.gridslam.occupancy import GridParams, TiledGrid, integrate_scan, scan_rays
from mazeslam.registration.correlative import CorrelativeParams, LikelihoodGrid, correlative_candidates
from mazeslam.registration.scan_matching import ReferenceScan, ScanMatchParams, laser_odometry, match_scan, scan_points

#: The prior of the wide search around the laser odometry's prediction: sigma (m, m, rad).
SEARCH_SIGMA = np.array([1.0, 1.0, 0.3])
#: A scan's best pose is wrong when this far from the reference (m, rad).
WRONG = (0.3, 0.1)
#: Likelihood of an end point in a never-observed cell in the "unknown" variant: the occupancy prior.
UNKNOWN_LIKELIHOOD = 0.5
#: Check 4: an end point fits the other scans when this close to one of their end points (m), and
#: two poses fit as well when their shares differ by at most TIE.
NEIGHBOUR_GAP = 0.1
TIE = 0.02


class UnknownAwareField(LikelihoodField):
    """The filter's likelihood field, except that an end point in a cell no beam has reached yet
    scores at least ``UNKNOWN_LIKELIHOOD`` (unknown occupancy) instead of as free space."""

    def __init__(self, window, params: MatchParams):
        super().__init__(window, params)
        self.unknown = window.values == 0

    def log_likelihood(self, poses: np.ndarray, points: np.ndarray, params: MatchParams) -> np.ndarray:
        world = np.stack([transform_points(pose, points) for pose in poses])  # (K, N, 2)
        distance, _ = self.lookup(world)
        likelihood = np.exp(-0.5 * (distance / params.sigma) ** 2)
        cell = np.floor((world - self.origin) / self.resolution).astype(int)
        inside = np.all((cell >= 0) & (cell < np.array(self.unknown.shape)), axis=-1)
        unknown = np.ones(distance.shape, dtype=bool)
        unknown[inside] = self.unknown[cell[inside][:, 0], cell[inside][:, 1]]
        likelihood = np.where(unknown, np.maximum(likelihood, UNKNOWN_LIKELIHOOD), likelihood)
        return params.scale * np.log(likelihood + params.floor).sum(axis=-1)


def beam_model_rows(run: LoadedRun, reference: np.ndarray, ranges: np.ndarray) -> list[dict]:
    """Check 1: the overlay's median gap (m) for each model variant."""
    from scipy.spatial import cKDTree

    beams = ranges.shape[1]
    step = np.pi / (beams - beams % 2)

    def gap(mount_x: float, offset: float, beam_step: float) -> float:
        bearings = -np.pi / 2 + offset + beam_step * np.arange(beams)
        clouds = []
        for pose, scan in zip(reference, ranges):
            valid = (scan > 0) & (scan < 15.0)
            local = np.column_stack(
                [mount_x + scan[valid] * np.cos(bearings[valid]), scan[valid] * np.sin(bearings[valid])]
            )
            clouds.append(transform_points(pose, local))
        gaps = []
        for before, after in zip(clouds[:-1], clouds[1:]):
            distance, _ = cKDTree(before).query(after)
            close = distance[distance < 0.5]
            gaps.append(np.median(close) if len(close) else 0.5)
        return float(np.mean(gaps))

    variants = [("mount x", m, (m, 0.0, step)) for m in (-0.2, -0.1, 0.0, 0.1, 0.2)]
    variants += [("beam offset [deg]", d, (0.0, np.radians(d), step)) for d in (-1.0, -0.5, 0.5, 1.0)]
    variants += [("beam step [deg]", 180 / 181, (0.0, 0.0, np.pi / 181))]
    return [{"variant": name, "value": value, "median gap [m]": gap(*args)} for name, value, args in variants]


def scan_to_map_row(
    run: LoadedRun, reference: np.ndarray, ranges: np.ndarray, increments: np.ndarray, cut: float, unknown: bool
) -> dict:
    """Check 2 for one variant: the wrong scans and why."""
    grid_params, match = GridParams(max_range=cut), MatchParams(max_range=cut)
    search = CorrelativeParams(resolution=0.1, sigma=0.1, turn_step=2.0, candidates=5, max_points=90)
    covariance = np.diag(SEARCH_SIGMA**2)
    information = np.linalg.inv(covariance)
    sensor = ScanSensor.of(run.geometry, ranges.shape[1])
    grid, wrong, preferred = TiledGrid(grid_params), [], 0
    field_kind = UnknownAwareField if unknown else LikelihoodField
    for k, scan in enumerate(ranges):
        rays = scan_rays(scan, sensor.bearings, sensor.mount, grid_params)
        if k:
            points = match_points(scan, sensor.bearings, sensor.mount, match)
            prior = compose(reference[k - 1], increments[k])
            world = np.vstack([transform_points(prior, points), transform_points(reference[k], points)])
            field = field_kind(grid.window(*grid.tile_range(world, 1.5 + 3 * SEARCH_SIGMA[0])), match)
            candidates = correlative_candidates(
                LikelihoodGrid(field.occupied_points(), search), points, prior, covariance, search
            )
            refined = np.array([refine_pose(field, points, prior, information, match, s) for s in [prior, *candidates]])
            scores = field.objective(refined, points, prior, information, match)
            best = refined[np.argmax(scores)]
            if (
                np.hypot(*(best[:2] - reference[k, :2])) > WRONG[0]
                or abs(wrap_angle(best[2] - reference[k, 2])) > WRONG[1]
            ):
                at_reference = refine_pose(field, points, prior, information, match, reference[k])
                wrong.append(k)
                preferred += scores.max() > field.objective(at_reference[None], points, prior, information, match)[0]
        window = grid.window(
            *grid.tile_range(np.vstack([transform_points(reference[k], rays.reach), reference[k, :2]]), 1.5)
        )
        grid.store(window, integrate_scan(window, rays, reference[k], grid_params))
    return {
        "cut [m]": cut,
        "never-observed cell": "unknown (0.5)" if unknown else "free (filter)",
        "wrong scans": len(wrong),
        "model prefers the wrong pose": preferred,
        "scans": " ".join(map(str, wrong)),
    }


def scan_to_scan_rows(
    run: LoadedRun, ranges: np.ndarray, increments: np.ndarray, reference_increments: np.ndarray
) -> list[dict]:
    """Check 3: the scan matcher's objective from the reference and from the laser odometry."""
    params = ScanMatchParams(enabled=True)
    free = np.diag([100.0, 100.0, 10.0])  # no prior to speak of
    rows = []
    for k in range(1, len(ranges)):
        error = increments[k] - reference_increments[k - 1]
        if np.hypot(*error[:2]) <= 1.0:
            continue
        before = ReferenceScan(scan_points(ranges[k - 1], run.geometry, params), params)
        points = scan_points(ranges[k], run.geometry, params)
        at_reference = match_scan(before, points, reference_increments[k - 1], free, params)
        at_odometry = match_scan(before, points, increments[k], free, params)
        rows.append(
            {
                "interval": k,
                "reference increment": np.round(reference_increments[k - 1], 2).tolist(),
                "laser odometry": np.round(increments[k], 2).tolist(),
                "objective from reference": at_reference.objective,
                "objective from laser odometry": at_odometry.objective,
                "overlap ref / laser": f"{at_reference.overlap:.2f} / {at_odometry.overlap:.2f}",
            }
        )
    return rows


def neighbour_rows(
    run: LoadedRun, reference: np.ndarray, ranges: np.ndarray, increments: np.ndarray
) -> tuple[list[dict], list[int]]:
    """Check 4: each wrong interval's fit to the scans before and after it, at the reference pose and
    at the laser odometry's, and the scans where the past cannot tell the two apart."""
    from scipy.spatial import cKDTree

    sensor, match = ScanSensor.of(run.geometry, ranges.shape[1]), MatchParams()
    points = [match_points(scan, sensor.bearings, sensor.mount, match) for scan in ranges]

    def shares(k: int, poses: tuple[np.ndarray, ...], others: range) -> list[float]:
        """For each of ``poses`` (3,) of scan k: the share of its end points near those of ``others``."""
        tree = cKDTree(np.vstack([transform_points(reference[j], points[j]) for j in others]))
        return [float(np.mean(tree.query(transform_points(pose, points[k]))[0] < NEIGHBOUR_GAP)) for pose in poses]

    rows, ties = [], []
    for k in range(1, len(ranges)):
        laser = compose(reference[k - 1], increments[k])
        offset = relative(reference[k], laser)
        if np.hypot(*offset[:2]) <= WRONG[0] and abs(offset[2]) <= WRONG[1]:
            continue
        past, future = range(max(0, k - 10), k), range(k + 1, min(len(ranges), k + 4))
        row = {"scan": k, "laser odometry's pose from the reference's [m, m, rad]": np.round(offset, 2).tolist()}
        for name, others in (("past", past), ("future", future)):
            if len(others):
                row[f"{name}: at reference"], row[f"{name}: at laser odometry"] = shares(
                    k, (reference[k], laser), others
                )
        rows.append(row)
        if row["past: at laser odometry"] >= row["past: at reference"] - TIE:
            ties.append(k)
    return rows, ties


def ambiguity_floor(reference: np.ndarray, increments: np.ndarray, scans: list[int]) -> float:
    """Aligned ATE (m) of the reference with the laser odometry's pose at ``scans`` (each from the pose
    before it as then placed): what a filter that took the other, equally fitting pose pays there."""
    poses = reference.copy()
    for k in scans:
        poses[k] = compose(poses[k - 1], increments[k])
    return float(absolute_trajectory_error(poses, reference, align=True)["rmse"])


def main() -> None:
    run = imported_run("orebro")
    records = np.flatnonzero(run.log.is_scan)
    reference, ranges = run.truth[records], run.log.values[records]
    increments = laser_odometry(run.log, run.geometry, ScanMatchParams(enabled=True)).increments
    reference_increments = relative(reference[:-1], reference[1:])
    beam = pd.DataFrame(beam_model_rows(run, reference, ranges))
    to_map = pd.DataFrame(
        [
            scan_to_map_row(run, reference, ranges, increments, cut, unknown)
            for cut in (20.0, 40.0)
            for unknown in (False, True)
        ]
    )
    to_scan = pd.DataFrame(scan_to_scan_rows(run, ranges, increments, reference_increments))
    neighbours, ties = neighbour_rows(run, reference, ranges, increments)
    text = "\n\n".join(
        [
            "# orebro: can the scans alone tell? (experiments/carmen_grid/orebro_checks.py)",
            "1. Beam model: mean over the intervals of the median gap between consecutive scans' end "
            "points at the reference poses (the importer's model: mount 0, first beam -90 deg, 1 deg steps).",
            beam.to_markdown(index=False, floatfmt=".4f"),
            f"2. Scan to map: {len(ranges) - 1} scans matched against the map drawn from the reference poses "
            "before them, "
            "searched around the laser odometry's prediction (prior sigma 1 m, 0.3 rad): scans whose best pose is "
            "more than 0.3 m or 0.1 rad from the reference, and how many of them the objective prefers.",
            to_map.to_markdown(index=False),
            "3. Scan to scan where the laser odometry is more than 1 m off: the matcher's objective "
            "(lower is better) refined from the reference increment and from the laser odometry's.",
            to_scan.to_markdown(index=False, floatfmt=".1f"),
            "4. Past and future, where the laser odometry's pose is more than 0.3 m or 0.1 rad from the "
            f"reference: the share of scan k's end points within {NEIGHBOUR_GAP} m of those of scans k-10..k-1 "
            "(past) and k+1..k+3 (future) at their reference poses, with scan k at the reference pose and at "
            "the laser odometry's.",
            pd.DataFrame(neighbours).to_markdown(index=False, floatfmt=".2f"),
            f"The past fits the laser odometry's pose as well as the reference's (within {TIE}) or better at scans "
            f"{' '.join(map(str, ties))}. Taking the laser odometry's pose at those scans and the reference "
            f"everywhere else gives an aligned ATE of {ambiguity_floor(reference, increments, ties):.3f} m.",
        ]
    )
    (RESULTS / "orebro_checks.md").write_text(text + "\n")
    print(text)


if __name__ == "__main__":
    main()
