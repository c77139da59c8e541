"""The laser odometry's compiled scan match (mazeslam.registration.kernels) against the numpy and
k-d tree implementation it replaced (reference_scan_matching.py) and against brute force: the same
nearest neighbours, the same poses, scores and information up to the order of the sums."""

import dataclasses

import numpy as np
import pytest
import reference_scan_matching as reference
from conftest import SHARED_DATA
from test_scan_matching import FRONT_LASER, ROOM, scan_from

from mazeslam.core.geometry import compose
from mazeslam.data.loaded_run import load_run
from mazeslam.registration import kernels, scan_matching
from mazeslam.registration.scan_matching import ReferenceScan, ScanMatchParams, laser_odometry, scan_points


def brute_nearest(points, x, y, bound, count):
    """The ``count`` nearest points' indexes (count,) and squared distances below ``bound``, by
    sorting every distance; -1 and ``bound`` where fewer are within it."""
    squared = (points[:, 0] - x) ** 2 + (points[:, 1] - y) ** 2
    order = np.argsort(squared, kind="stable")[:count]
    within = squared[order] < bound
    return np.where(within, order, -1), np.where(within, squared[order], bound)


@pytest.mark.parametrize("spread", [0.05, 3.0, 400.0])
def test_the_buckets_find_the_nearest_point_as_brute_force_does(spread):
    """Clustered, room-sized and wide point sets (wide: buckets larger than MIN_CELL), queries
    inside, beside and far outside them, bounds from 1 cm to 100 m, the 1 to 6 nearest."""
    rng = np.random.default_rng(3)
    points = rng.normal(0.0, spread, (300, 2))
    grid = kernels.buckets(points)
    for _ in range(2000):
        x, y = rng.normal(0.0, 2 * spread, 2)
        bound = float(rng.choice([1e-4, 0.01, 1.0, 1e4]))
        count = int(rng.integers(1, 7))
        found, squared = np.full(count, -1), np.full(count, bound)
        kernels.nearest(points, grid, x, y, found, squared)
        expected, expected_squared = brute_nearest(points, x, y, bound, count)
        np.testing.assert_array_equal(found, expected)
        np.testing.assert_array_equal(squared, expected_squared)


def test_points_equally_near_come_lower_index_first():
    """Four points 1 m from the query and a fifth beside them, in an order no bucket keeps: the
    result is a function of the points alone (distance, then index), whatever the buckets visit first."""
    points = np.array([[0.0, -1.0], [5.0, 5.0], [1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, 1.0]])
    found, squared = np.full(5, -1), np.full(5, 100.0)
    kernels.nearest(points, kernels.buckets(points), 0.0, 0.0, found, squared)
    np.testing.assert_array_equal(found, [0, 2, 3, 4, 5])
    np.testing.assert_array_equal(squared, [1.0, 1.0, 1.0, 1.0, 1.0])


def test_a_point_exactly_at_the_bound_is_not_found():
    points = np.array([[0.0, 0.0], [3.0, 4.0]])
    grid = kernels.buckets(points)
    for bound, expected in ((0.25, -1), (np.nextafter(0.25, 1.0), 0)):
        found, squared = np.full(1, -1), np.full(1, bound)
        kernels.nearest(points, grid, 0.5, 0.0, found, squared)
        assert found[0] == expected


def room_pairs(count=12, seed=5):
    """Scan pairs in ROOM with 1 cm range noise: (reference scan, points, prior, prior covariance)."""
    rng = np.random.default_rng(seed)
    params = ScanMatchParams()
    for _ in range(count):
        first = np.array([rng.uniform(1.5, 4.0), rng.uniform(1.5, 6.5), rng.uniform(-np.pi, np.pi)])
        motion = np.array([rng.uniform(0.0, 0.6), rng.normal(0.0, 0.05), rng.normal(0.0, 0.2)])
        before = scan_points(scan_from(first, ROOM, 0.01, rng), FRONT_LASER, params)
        after = scan_points(scan_from(compose(first, motion), ROOM, 0.01, rng), FRONT_LASER, params)
        prior = motion + rng.normal(0.0, [0.05, 0.05, 0.03])
        yield ReferenceScan(before, params), after, prior, np.diag([0.1**2, 0.1**2, 0.05**2])


def test_the_compiled_match_equals_the_numpy_match_on_noisy_room_scans():
    params = ScanMatchParams()
    for scan, points, prior, covariance in room_pairs():
        compiled = scan_matching.match_scan(scan, points, prior, covariance, params)
        expected = reference.match_scan(scan, points, prior, covariance, params)
        np.testing.assert_allclose(compiled.pose, expected.pose, rtol=0, atol=1e-10)
        assert compiled.objective == pytest.approx(expected.objective, rel=1e-9)
        assert compiled.overlap == expected.overlap
        np.testing.assert_allclose(
            scan_matching.match_information(scan, points, compiled.pose, params),
            reference.match_information(scan, points, compiled.pose, params),
            rtol=1e-9,
            atol=1e-9,
        )


def test_the_compiled_laser_odometry_equals_the_numpy_one_on_a_carmen_log(tmp_path, monkeypatch):
    """aces's first 60 scans (real SICK scans, wheel priors): every increment, acceptance and
    overlap as the numpy matcher gives them."""
    carmen = SHARED_DATA / "carmen" / "aces-corrected.log.gz"
    if not carmen.exists():
        pytest.skip(f"CARMEN log not found at {carmen} (the shared data folder is absent)")
    from mazeslam.data.carmen import import_carmen

    import_carmen(carmen, tmp_path / "aces.log")
    run = load_run(tmp_path / "aces.log")
    end = int(np.flatnonzero(run.log.is_scan)[60]) + 1
    log = dataclasses.replace(
        run.log, times=run.log.times[:end], flags=run.log.flags[:end], values=run.log.values[:end]
    )
    params = ScanMatchParams(enabled=True)
    compiled = laser_odometry(log, run.geometry, params)
    monkeypatch.setattr(scan_matching, "match_scan", reference.match_scan)
    expected = laser_odometry(log, run.geometry, params)
    np.testing.assert_allclose(compiled.increments, expected.increments, rtol=0, atol=1e-10)
    np.testing.assert_array_equal(compiled.accepted, expected.accepted)
    np.testing.assert_array_equal(compiled.overlap, expected.overlap)


def test_the_surface_normals_are_numpys_eigenvectors_of_the_k_nearest_points():
    """Noisy room scans: the same normals up to sign, the same straight surfaces."""
    params = ScanMatchParams()
    for scan, _, _, _ in room_pairs():
        normals, straight = reference.surface_normals(scan.points, params.neighbours, params.max_flatness)
        np.testing.assert_allclose(np.abs(np.sum(scan.normals * normals, axis=1)), 1.0, rtol=0, atol=1e-9)
        np.testing.assert_array_equal(scan.straight, straight)
