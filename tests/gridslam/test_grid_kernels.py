"""The grid filter's compiled kernels against the filter as it was written before them
(tests/gridslam/reference_grid_filter.py: numpy, and OpenCV's distance transform for the likelihood
field): the same distances, matches, scores and maps, and the same filter run."""

from unittest import mock

import numpy as np
import pytest
from reference_grid_filter import ReferenceField, ReferenceGridSlam
from reference_grid_filter import integrate_scan as reference_integrate_scan
from reference_grid_filter import refine_pose as reference_refine_pose

from mazeslam.core.geometry import compose
from mazeslam.data.log import read
from mazeslam.gridslam import GridSlamParams, filter, run_grid_slam
from mazeslam.gridslam.filter import SearchMode
from mazeslam.gridslam.matching import LikelihoodField, MatchParams, field_reach, refine_pose
from mazeslam.gridslam.occupancy import GridParams, Window, integrate_scan, scan_rays
from mazeslam.sim.building import simulate_building_log

RESOLUTION = 0.05
MATCH = MatchParams()


def walls_window(seed: int, shape=(128, 192), walls: int = 6) -> Window:
    """A window of log-odds (float32) with a few random straight walls of occupied cells, some
    free cells and a lone occupied cell, origin off the world's."""
    rng = np.random.default_rng(seed)
    values = rng.uniform(-2.0, -0.1, shape).astype(np.float32) * (rng.random(shape) < 0.5)
    for _ in range(walls):
        start, end = rng.uniform(0, 1, 2) * shape, rng.uniform(0, 1, 2) * shape
        along = np.linspace(0, 1, 400)[:, None]
        cells = np.floor(start + along * (end - start)).astype(int)
        values[cells[:, 0], cells[:, 1]] = rng.uniform(0.1, 3.0)
    values[rng.integers(shape[0]), rng.integers(shape[1])] = 0.5
    return Window(values, np.array([-1.3, 2.7]), RESOLUTION, np.array([0, 0]))


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("walls", [0, 1, 6])
def test_the_distance_at_every_cell_is_the_distance_transform(seed, walls):
    window = walls_window(seed, walls=walls)  # 0 walls: one occupied cell, far from most
    field, reference = LikelihoodField(window, MATCH), ReferenceField(window, MATCH)
    i, j = np.indices(window.values.shape[:2]).reshape(2, -1)
    centres = window.origin + (np.column_stack([i, j]) + 0.5) * RESOLUTION
    inside = (i < window.values.shape[0] - 1) & (j < window.values.shape[1] - 1)  # read as corner (0, 0)
    distance, _ = field.lookup(centres[inside])
    expected, _ = reference.lookup(centres[inside])
    np.testing.assert_array_equal(distance, expected)


@pytest.mark.parametrize("seed", range(3))
def test_lookups_anywhere_match_the_reference_bilinear_field(seed):
    window = walls_window(seed)
    points = np.random.default_rng(seed).uniform(-3, 12, (2000, 2))  # inside the window and beyond it
    field, reference = LikelihoodField(window, MATCH), ReferenceField(window, MATCH)
    for got, expected in zip(field.lookup(points), reference.lookup(points)):
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12)


def scan_points(seed: int, count: int = 150) -> np.ndarray:
    """End points (N, 2) of a scan in the robot frame: around the robot, 1-5 m away."""
    rng = np.random.default_rng(seed)
    angles, ranges = rng.uniform(-np.pi, np.pi, count), rng.uniform(1, 5, count)
    return np.column_stack([ranges * np.cos(angles), ranges * np.sin(angles)])


@pytest.mark.parametrize("seed", range(4))
def test_refinement_scores_and_overlap_match_the_reference(seed):
    window, points = walls_window(seed), scan_points(seed)
    field, reference = LikelihoodField(window, MATCH), ReferenceField(window, MATCH)
    prior = np.array([3.1, 6.2, 0.4])
    information = np.diag([1 / 0.05**2, 1 / 0.05**2, 1 / 0.02**2])
    start = prior + [0.04, -0.03, 0.01]
    refined = reference_refine_pose(reference, points, prior, information, MATCH, start)
    np.testing.assert_allclose(refine_pose(field, points, prior, information, MATCH, start), refined, rtol=0, atol=1e-9)
    poses = prior + np.random.default_rng(seed).normal(0, 0.05, (27, 3))
    np.testing.assert_allclose(
        field.objective(poses, points, prior, information, MATCH),
        reference.objective(poses, points, prior, information, MATCH),
        rtol=1e-12,
    )
    for pose in poses[:5]:
        assert field.overlap(pose, points, MATCH) == reference.overlap(pose, points, MATCH)


@pytest.mark.parametrize("seed", range(3))
@pytest.mark.parametrize("step", [0.4 * RESOLUTION, 3.0 * RESOLUTION])
def test_scores_of_poses_sharing_headings_match_the_reference(seed, step):
    """The stencil's layout, 3 headings of 9 shifts each: shifts within a cell share one block of
    corners (0.4 cells), shifts of 3 cells each read their own, and a point off the window's edge
    clamps its corners into it (the scan reaches past the window)."""
    window, points = walls_window(seed), scan_points(seed, count=400) * 1.8
    field, reference = LikelihoodField(window, MATCH), ReferenceField(window, MATCH)
    prior, information = np.array([3.1, 6.2, 0.4]), np.diag([400.0, 400.0, 2500.0])
    stencil = np.array([(x, y, t) for x in (-1, 0, 1) for y in (-1, 0, 1) for t in (-1, 0, 1)], dtype=float)
    poses = prior + stencil * [step, step, 0.01]
    np.testing.assert_allclose(
        field.objective(poses, points, prior, information, MATCH),
        reference.objective(poses, points, prior, information, MATCH),
        rtol=1e-12,
    )


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("clear_to", [0.0, 6.0])
def test_integration_writes_the_same_cells_and_tiles(seed, clear_to):
    rng = np.random.default_rng(seed)
    params = GridParams(resolution=RESOLUTION, tile_size=32, max_range=5.0)
    bearings = np.linspace(-np.pi, np.pi, 361)[:-1]
    ranges = np.where(rng.random(360) < 0.1, 0.0, rng.uniform(0.05, 7.0, 360))
    rays = scan_rays(ranges, bearings, np.array([0.1, 0.0]), params, clear_to)
    window = walls_window(seed)
    expected = Window(window.values.copy(), window.origin, RESOLUTION, window.lower_tile)
    pose = np.array([3.3, 4.9, rng.uniform(-np.pi, np.pi)])
    changed = integrate_scan(window, rays, pose, params)
    np.testing.assert_array_equal(changed, reference_integrate_scan(expected, rays, pose, params))
    np.testing.assert_array_equal(window.values, expected.values)
    assert changed.any()


@pytest.fixture(scope="module")
def building_log(tmp_path_factory):
    simulated = simulate_building_log(tmp_path_factory.mktemp("kernels") / "building.log", laps=0.5)
    return simulated, read(simulated.path)


def run_with(slam_type, building_log, params: GridSlamParams):
    simulated, course_log = building_log
    with mock.patch.object(filter, "GridSlam", slam_type):
        return run_grid_slam(course_log, simulated.geometry, simulated.start_pose, params)


@pytest.mark.parametrize(
    ("search", "min_overlap"),
    [(SearchMode.FAILED_MATCH, 0.4), (SearchMode.EVERY_SCAN, 0.4), (SearchMode.FAILED_MATCH, 0.9)],
)
def test_the_compiled_filter_runs_as_the_reference_with_the_same_seed(building_log, search, min_overlap):
    """The same path, weights, resamplings and map as the filter written before the kernels; with
    ``min_overlap`` 0.9 many matches fail and go through the rescue, particle by particle."""
    params = GridSlamParams(particles=6, seed=3, search=search, match=MatchParams(min_overlap=min_overlap))
    compiled = run_with(filter.GridSlam, building_log, params)
    reference = run_with(ReferenceGridSlam, building_log, params)
    assert compiled.processed.sum() > 20
    if min_overlap > 0.5:
        assert np.nanmin(compiled.matched) < 0.9  # some particles' matches failed
    np.testing.assert_allclose(compiled.best_poses, reference.best_poses, rtol=0, atol=1e-6)
    np.testing.assert_allclose(compiled.particles.log_weights, reference.particles.log_weights, atol=1e-6)
    np.testing.assert_array_equal(compiled.resampled, reference.resampled)
    np.testing.assert_array_equal(compiled.grid.dense()[0], reference.grid.dense()[0])


def test_the_precompile_room_is_measured_to_its_walls():
    from mazeslam.gridslam.precompile import ROOM, room_log, room_ranges

    ranges = room_ranges(np.array([0.0, 0.0, 0.0]), np.array([0.0, np.pi / 2, np.pi, -np.pi / 2, np.pi / 4]))
    np.testing.assert_allclose(ranges, [4.0, 1.5, 1.0, 1.5, 1.5 * np.sqrt(2)])
    course_log, geometry = room_log(scans=3)
    assert list(course_log.flags) == [0, 1, 0, 1, 0, 1] and course_log.width == len(geometry.bearings(course_log.width))
    assert np.all(course_log.values[1::2] <= np.hypot(*(ROOM[1] - ROOM[0])))


def test_each_particles_box_holds_its_placed_points_and_touches_them():
    rng = np.random.default_rng(4)
    starts = np.concatenate([rng.uniform(-5, 5, (7, 3, 2)), rng.uniform(-np.pi, np.pi, (7, 3, 1))], axis=2)
    points = rng.uniform(-8, 8, (40, 2))
    for with_starts in (False, True):
        boxes = filter._bounds(starts, points, with_starts)
        for particle, box in enumerate(boxes):
            placed = [
                compose(start, np.column_stack([points, np.zeros(len(points))]))[:, :2] for start in starts[particle]
            ]
            placed = np.vstack(placed + ([starts[particle, :, :2]] if with_starts else []))
            np.testing.assert_allclose(box, [placed.min(axis=0), placed.max(axis=0)], rtol=0, atol=1e-12)


@pytest.mark.parametrize("sigma_schedule", [(0.3, 0.15, 0.05), (0.04, 0.02, 0.01)])
def test_the_field_is_the_distance_to_a_lone_wall_cell_clipped_at_its_reach(sigma_schedule):
    """One occupied cell in a 160 x 120 window: every cell centre's distance is the hypotenuse of its
    cell offsets, times the resolution, up to 5 sigmas of the widest stage (field_reach), and
    exactly the reach beyond it."""
    params = MatchParams(sigma=sigma_schedule[-1], sigma_schedule=sigma_schedule)
    values = np.full((160, 120), -1.0, dtype=np.float32)
    values[70, 50] = 2.0
    window = Window(values, np.array([0.4, -2.0]), RESOLUTION, np.array([0, 0]))
    reach = field_reach(params, RESOLUTION)
    assert reach == pytest.approx(5 * sigma_schedule[0] / RESOLUTION)
    i, j = np.indices((159, 119)).reshape(2, -1)  # every centre read as a lookup's corner (0, 0)
    centres = window.origin + (np.column_stack([i, j]) + 0.5) * RESOLUTION
    distance, _ = LikelihoodField(window, params).lookup(centres)
    expected = np.minimum(np.hypot(i - 70, j - 50), np.float32(reach)) * RESOLUTION
    np.testing.assert_allclose(distance, expected, rtol=1e-6, atol=1e-9)
    assert np.any(np.hypot(i - 70, j - 50) > reach)  # the window reaches beyond the clip
