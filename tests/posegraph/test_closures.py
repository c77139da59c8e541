"""Scan-to-submap matching and its ambiguity test on simulated corridors (the virtual laser, 1 cm
noise): a corridor whose pillars repeat every 2 m is refused (two equally good modes within the
window), a featureless one too (nothing fixes the motion along it), and one whose pillars are
irregular is accepted at the true pose."""

import numpy as np
import pytest

from mazeslam.core.geometry import relative
from mazeslam.posegraph.closures import (
    build_submap,
    candidate_pairs,
    chain_window,
    keyframes,
    match_to_submap,
    submap_members,
    voxel_thinned,
)
from mazeslam.posegraph.graph import EdgeKind
from mazeslam.posegraph.params import ClosureParams, SequentialParams
from mazeslam.registration.scan_matching import ScanMatchParams, scan_points
from mazeslam.sim.building import LASER
from mazeslam.sim.laser import VirtualLaser

SCAN = ScanMatchParams(enabled=True, max_range=8.0)


def _box(x0, y0, x1, y1):
    return [[x0, y0, x1, y0], [x1, y0, x1, y1], [x1, y1, x0, y1], [x0, y1, x0, y0]]


def _corridor(pillars) -> np.ndarray:
    """A corridor 2 m wide and 200 m long along x, with 0.4 x 0.3 m pillars against its lower wall at ``pillars``."""
    walls = [[-100.0, 0.0, 100.0, 0.0], [-100.0, 2.0, 100.0, 2.0]]
    for x in pillars:
        walls += _box(x, 0.0, x + 0.4, 0.3)
    return np.array(walls)


def _match(walls, true_offset, guess_offset, window_sigma=1.0):
    """The submap of scans from x = -4..4 (every metre, facing both ways, anchored at the first)
    and the query at ``true_offset`` (x) facing +x, matched from a guess ``guess_offset`` (x; or
    several) with a ``window_sigma`` m, 0.1 rad window; returns within 8 m, so that the submap
    covers all the query sees at every pose the window reaches."""
    rng = np.random.default_rng(0)
    laser = VirtualLaser(LASER, walls)
    mapped = [[x, 1.0, heading] for heading in (0.0, np.pi) for x in np.arange(-4.0, 4.5, 1.0)]
    poses = np.array([*mapped, [true_offset, 1.0, 0.0]])
    points = [scan_points(laser.scan(pose, rng), LASER.geometry, SCAN) for pose in poses]
    params = ClosureParams()
    submap = build_submap(0, np.arange(len(mapped)), poses, points, params, SCAN)
    assert submap is not None
    guess = np.array([relative(poses[0], [x, 1.0, 0.0]) for x in np.atleast_1d(guess_offset)])
    window = np.diag([window_sigma**2, window_sigma**2, 0.1**2])
    match = match_to_submap(submap, points[-1], guess, window, params, SCAN, SequentialParams())
    return match, relative(poses[0], poses[-1])


def test_a_corridor_with_pillars_every_two_metres_is_refused_as_ambiguous():
    match, _ = _match(_corridor(np.arange(-100.0, 100.0, 2.0) + 0.3), true_offset=2.0, guess_offset=2.5)
    assert match.refusal == "ambiguous"
    assert match.second < match.best / ClosureParams().ambiguity_ratio


def test_pillars_two_metres_apart_are_told_apart_only_when_each_is_searched():
    # A guess one pillar spacing ahead of the truth and a narrow window (0.1 m): the one search
    # sees one mode, and accepts it 2 m off. Searched around that guess and around the true step's
    # (the modes of an ambiguous scan-to-scan step between the two scans), the two modes are as
    # good: refused as ambiguous.
    corridor = _corridor(np.arange(-100.0, 100.0, 2.0) + 0.3)
    narrow, truth = _match(corridor, true_offset=2.0, guess_offset=4.0, window_sigma=0.1)
    assert narrow.accepted and narrow.pose[0] == pytest.approx(truth[0] + 2.0, abs=0.05)
    both, _ = _match(corridor, true_offset=2.0, guess_offset=[4.0, 2.0], window_sigma=0.1)
    assert both.refusal == "ambiguous"
    np.testing.assert_allclose(np.sort(both.modes[:2, 0]), [truth[0], truth[0] + 2.0], atol=0.05)


def test_a_featureless_corridor_is_refused():
    match, _ = _match(_corridor([]), true_offset=2.0, guess_offset=2.5)
    assert not match.accepted
    assert match.refusal in ("ambiguous", "degenerate")


def test_a_corridor_with_irregular_pillars_is_accepted_at_the_true_pose():
    pillars = [-11.2, -7.1, -3.0, 1.3, 3.4, 4.1, 7.7, 9.2, 13.9, 16.0]
    match, truth = _match(_corridor(pillars), true_offset=2.0, guess_offset=2.5)
    assert match.accepted, match
    assert match.pose == pytest.approx(truth, abs=0.03)
    assert np.all(np.linalg.eigvalsh(match.covariance) > 0)


def test_keyframes_and_candidate_pairs_follow_the_path():
    # Out along x for 20 m, back along y = 1: the way back passes the way out.
    out = np.column_stack([np.arange(0, 20, 0.1), np.zeros(200), np.zeros(200)])
    back = np.column_stack([np.arange(20, 0, -0.1), np.ones(200), np.full(200, np.pi)])
    poses = np.vstack([out, back])
    keys = keyframes(poses, 0.5, 0.25)
    assert np.all(np.diff(keys) <= 5) and keys[0] == 0
    cumulative = np.column_stack([np.arange(400) * 1e-4, np.arange(400) * 1e-5])
    pairs = candidate_pairs(poses, keys, cumulative, ClosureParams())
    local = [(a, q) for a, q, kind in pairs if kind == EdgeKind.LOCAL]
    closures = [(a, q) for a, q, kind in pairs if kind == EdgeKind.CLOSURE]
    steps = {int(np.searchsorted(keys, a) - np.searchsorted(keys, q)) for a, q in local}
    anchors = set(ClosureParams().local_anchors)
    assert steps == {-back for back in anchors} | anchors  # the keyframes behind and ahead
    assert closures and all(a < 200 <= q for a, q in closures)  # only the way back closes on the way out
    assert all(abs(poses[a, 0] - poses[q, 0]) < 4.0 for a, q in closures)


def test_voxel_thinning_keeps_one_point_per_cell():
    points = np.array([[0.01, 0.01], [0.02, 0.03], [0.06, 0.01], [0.01, 0.07]])
    np.testing.assert_array_equal(voxel_thinned(points, 0.05), points[[0, 2, 3]])


def test_a_submap_holds_the_anchors_side_of_the_path_and_not_the_querys_neighbours():
    # Keyframes every 0.5 m along a straight path; submaps reach 3 m of path from their anchor.
    keys = np.arange(0, 40, 2)
    path = 0.25 * np.arange(40)
    params = ClosureParams()
    behind = submap_members(10, 20, keys, path, params)  # the query's preceding keyframe is 18
    np.testing.assert_array_equal(behind, np.arange(0, 17, 2))  # 0 .. 5.5 m of path, before 18
    ahead = submap_members(30, 20, keys, path, params)  # its following keyframe is 22
    np.testing.assert_array_equal(ahead, np.arange(24, 39, 2))  # 4.5 .. 10.5 m of path, after 22
    near = submap_members(24, 20, keys, path, params)  # the anchor itself is always a member
    assert 22 not in near and 24 in near and near.min() > 22


def test_the_search_window_is_the_chains_whichever_side_the_anchor_is_on():
    # 10 intervals of 1 m, each 0.02^2 m^2 and 0.01^2 rad^2: between scans 2 and 6, 4 intervals.
    cumulative = np.column_stack([np.arange(11) * 0.02**2, np.arange(11) * 0.01**2])
    path = np.arange(11.0)
    params = ClosureParams(min_window=(0.001, 0.001))
    behind, ahead = chain_window(cumulative, path, 2, 6, params), chain_window(cumulative, path, 6, 2, params)
    np.testing.assert_array_equal(behind, ahead)
    position = 4 * 0.02**2 + 4.0**2 * 4 * 0.01**2 / 3  # the summed variance plus the heading's swing
    np.testing.assert_allclose(np.diag(behind), [position, position, 4 * 0.01**2])
