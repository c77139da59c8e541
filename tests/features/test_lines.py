import math

import numpy as np
import pytest

from mazeslam.features.lines import LineParams, SplitAndMerge, fit_line


def points_on(r, alpha, along):
    """Points of the line x cos(alpha) + y sin(alpha) = r at along-line coordinates ``along``."""
    normal = np.array([math.cos(alpha), math.sin(alpha)])
    direction = np.array([-math.sin(alpha), math.cos(alpha)])
    return r * normal + np.asarray(along)[:, None] * direction


@pytest.mark.parametrize(
    "points, r, alpha",
    [
        ([[2, 0], [2, 1], [2, -3]], 2.0, 0.0),  # vertical line x = 2
        ([[-2, 5], [-2, 1], [-2, 0]], 2.0, math.pi),  # x = -2: alpha at the top of (-pi, pi]
        ([[0, -3], [1, -3], [5, -3]], 3.0, -math.pi / 2),  # horizontal line y = -3
        ([[0, 1], [1, 2], [3, 4]], 1 / math.sqrt(2), 3 * math.pi / 4),  # y = x + 1
    ],
)
def test_fit_line_hand_computed(points, r, alpha):
    fitted_r, fitted_alpha = fit_line(points)
    assert fitted_r == pytest.approx(r)
    assert fitted_alpha == pytest.approx(alpha)


def test_fit_line_through_the_origin():
    r, alpha = fit_line([[1, 2], [2, 4], [-1, -2]])  # y = 2x
    assert r == pytest.approx(0.0, abs=1e-12)
    assert abs(math.cos(alpha) * 1 + math.sin(alpha) * 2) < 1e-12  # (1, 2) is on the line


def test_fit_line_near_the_origin_keeps_r_non_negative():
    for offset in (1e-4, -1e-4):
        r, alpha = fit_line([[-1, offset], [0, offset], [1, offset]])
        assert r == pytest.approx(1e-4)
        assert alpha == pytest.approx(math.pi / 2 if offset > 0 else -math.pi / 2)


def test_fit_line_minimises_squared_perpendicular_distances():
    rng = np.random.default_rng(0)
    points = points_on(0.7, 0.4, np.linspace(-1, 1, 30)) + rng.normal(0, 0.05, (30, 2))
    r, alpha = fit_line(points)

    def cost(r_, a_):
        return np.sum((points @ [math.cos(a_), math.sin(a_)] - r_) ** 2)

    for dr, da in [(1e-3, 0), (-1e-3, 0), (0, 1e-3), (0, -1e-3)]:
        assert cost(r, alpha) < cost(r + dr, alpha + da)


def test_fit_line_rejects_too_few_points():
    with pytest.raises(ValueError, match="at least two points"):
        fit_line([[1.0, 2.0]])


def test_line_covariance_matches_monte_carlo():
    rng = np.random.default_rng(1)
    clean = points_on(0.5, 0.3, np.linspace(0.1, 0.6, 25))
    sigma = 0.005
    splitter = SplitAndMerge(LineParams(split_threshold=1.0, min_length=0.0, range_noise_std=sigma))
    fits, predicted = [], []
    for _ in range(3000):
        noisy = clean + rng.normal(0, sigma / math.sqrt(2), clean.shape)  # perpendicular sd = sigma/sqrt(2)
        segment = splitter.segment(noisy, [(0, len(noisy) - 1)])[0]
        fits.append([segment.r, segment.alpha])
        predicted.append(segment.covariance / segment.noise_var)
    empirical = np.cov(np.array(fits).T)
    expected = np.mean(predicted, axis=0) * (sigma**2 / 2)
    np.testing.assert_allclose(np.diag(empirical), np.diag(expected), rtol=0.1)
    assert empirical[0, 1] == pytest.approx(expected[0, 1], rel=0.15)


def test_split_finds_the_two_walls_of_an_l():
    along = np.linspace(0, 0.3, 16)
    up = points_on(0.2, 0.0, along)  # x = 0.2, from y = 0 up to the corner (0.2, 0.3)
    left = points_on(0.3, math.pi / 2, along[1:] - 0.2)  # y = 0.3, from the corner leftwards
    points = np.vstack([up, left])
    segments = SplitAndMerge(LineParams()).segment(points, [(0, len(points) - 1)])
    assert len(segments) == 2
    assert (segments[0].r, segments[0].alpha) == pytest.approx((0.2, 0.0), abs=1e-9)
    assert (segments[1].r, segments[1].alpha) == pytest.approx((0.3, math.pi / 2), abs=1e-9)
    assert (segments[0].first, segments[0].last, segments[1].last) == (0, 15, 30)  # split at the corner


def test_collinear_runs_merge_and_stubs_are_dropped():
    line = points_on(0.5, 1.0, np.linspace(-0.3, 0.3, 40))
    stub = np.array([[2.0, 2.0], [2.1, 2.0], [2.2, 2.05]])
    points = np.vstack([line, stub])
    segments = SplitAndMerge(LineParams()).segment(points, [(0, 19), (20, 39), (40, 42)])
    assert len(segments) == 1
    assert (segments[0].first, segments[0].last) == (0, 39)
    assert segments[0].length == pytest.approx(0.6)


def test_short_segments_are_dropped():
    points = points_on(0.5, 0.0, np.linspace(0, 0.02, 10))
    assert SplitAndMerge(LineParams(min_length=0.03)).segment(points, [(0, 9)]) == []


@pytest.mark.parametrize("kwargs", [{"split_threshold": 0}, {"min_points": 1}, {"breakpoint_angle": 95}])
def test_impossible_line_parameters(kwargs):
    with pytest.raises(ValueError):
        LineParams(**kwargs)
