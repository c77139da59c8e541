import dataclasses
import math

import numpy as np
import pytest
from conftest import EXACT

from mazeslam.fastslam.filter import Candidates, FastSLAM, FastSLAMParams


def observe(pose, landmark):
    """Exact range and bearing of a world landmark from a pose."""
    dx, dy = landmark[0] - pose[0], landmark[1] - pose[1]
    return np.array([[math.hypot(dx, dy), math.remainder(math.atan2(dy, dx) - pose[2], 2 * math.pi)]])


def test_new_landmark_is_placed_where_it_is_seen():
    slam = FastSLAM(EXACT, start_pose=(1.0, 2.0, math.pi / 2))
    report = slam.update(np.array([[0.5, -math.pi / 2]]))  # 0.5 m to the right of a robot facing +y
    assert report.new == 1
    means, covariances = slam.landmarks()
    np.testing.assert_allclose(means, [[1.5, 2.0]], atol=1e-12)
    # Covariance G R G^T: range noise along x (the direction of the landmark), bearing noise x 0.5 m along y.
    np.testing.assert_allclose(covariances[0], np.diag([0.01**2, (0.5 * 0.01) ** 2]), atol=1e-15)


def test_repeated_observations_shrink_the_landmark_like_an_average():
    slam = FastSLAM(EXACT)
    rng = np.random.default_rng(0)
    landmark = np.array([0.3, 0.4])
    for _ in range(50):
        z = observe((0, 0, 0), landmark) + rng.normal(0, 0.01, (1, 2)) * [1, 1]
        slam.update(z)
    means, covariances = slam.landmarks()
    assert len(means) == 1
    assert np.hypot(*(means[0] - landmark)) < 0.005
    # 50 observations of noise R: the covariance is about R(mapped)/50.
    first = FastSLAM(EXACT)
    first.update(observe((0, 0, 0), landmark))
    np.testing.assert_allclose(np.linalg.det(covariances[0]), np.linalg.det(first.landmarks()[1][0]) / 50**2, rtol=0.2)


def explicit_distance2(slam: FastSLAM, observations, noise, with_pose_uncertainty: bool) -> np.ndarray:
    """(P, K, M) squared Mahalanobis distance of every observation to every slot of every particle,
    from the explicit matrices: S = H Sigma H^T (+ Gx Sigma_x Gx^T) + R, nu^T S^-1 nu."""
    dx = slam.means[:, None, :, 0] - slam.poses[:, None, None, 0]  # (P, 1, M)
    dy = slam.means[:, None, :, 1] - slam.poses[:, None, None, 1]
    q, zero = dx**2 + dy**2, np.zeros_like(dx)
    rho = np.sqrt(q)
    h = np.stack([np.stack([dx / rho, dy / rho], -1), np.stack([-dy / q, dx / q], -1)], -2)  # (P, 1, M, 2, 2)
    s = h @ slam.covariances[:, None] @ np.swapaxes(h, -1, -2) + noise[None, :, None]
    if with_pose_uncertainty:
        gx = np.stack([np.stack([-dx / rho, -dy / rho, zero], -1), np.stack([dy / q, -dx / q, zero - 1], -1)], -2)
        s = s + gx @ slam.pose_covariances[:, None, None] @ np.swapaxes(gx, -1, -2)
    bearing = np.arctan2(dy, dx) - slam.poses[:, None, None, 2]
    nu = np.stack(
        [observations[None, :, None, 0] - rho, np.angle(np.exp(1j * (observations[None, :, None, 1] - bearing)))], -1
    )
    return np.einsum("pkmi,pkmi->pkm", nu, np.linalg.solve(s, nu[..., None])[..., 0])


def spread(model, slots: int) -> np.ndarray:
    """(P, K, ``slots``) the model's squared distances over the first slots (inf where not modelled)."""
    p, k, _ = model.distance2.shape
    whole = np.full((p, k, slots), np.inf)
    whole[:, :, model.candidates.slots] = model.distance2
    return whole


@pytest.mark.parametrize("version", [1, 2])
@pytest.mark.parametrize("mixed", [False, True])
def test_landmarks_left_out_of_the_model_could_not_have_mattered(version, mixed):
    """The spatial index keeps every observation-slot pair, and the cull within the pairs every
    particle's landmark, that is within the new-landmark gate; what it keeps is modelled as the
    explicit matrices give. ``mixed``: as in a maze, where corners lie a few centimetres apart and
    particles' slots hold different ones of them, each slot holds one of four landmarks 4 cm apart
    in each particle."""
    rng = np.random.default_rng(version)
    p = 50
    params = FastSLAMParams(NPARTICLES=p, version=version, seed=version)
    slam = FastSLAM(params, capacity=64)
    slam.exists[:, :60] = rng.uniform(size=(p, 60)) < 0.9
    slam.means[:, :60] = rng.uniform(-3, 3, (60, 2)) + rng.normal(0, 0.02, (p, 60, 2))  # particles' maps agree
    if mixed:
        slam.means[:, :60] += 0.04 * rng.integers(0, 2, (p, 60, 2))
    slam.poses += rng.normal(0, [0.03, 0.03, 0.1], (p, 3))
    slam.covariances[:, :60] = np.eye(2) * rng.uniform(1e-5, 5e-3, (p, 60, 1, 1))
    slam.pose_covariances[:] = [[1e-3, 2e-4, 3e-4], [2e-4, 2e-3, -1e-4], [3e-4, -1e-4, 1e-2]]
    slam.reindex()
    observations = np.column_stack([rng.uniform(0.05, 0.8, 6), rng.uniform(-math.pi, math.pi, 6)])
    noise = params.observation_noise(np.tile(np.diag([1e-4, 1e-2]), (6, 1, 1)), 6)
    truth = explicit_distance2(slam, observations, noise, version == 2)[:, :, :60]
    culled = slam._candidates(observations, noise, 60)
    model = slam._model(observations, noise, culled, version == 2)
    modelled = np.isfinite(spread(model, 60))  # particle-observation-slot triples computed
    held = slam.exists[:, None, :60]
    near = np.zeros((6, 60), dtype=bool)
    near[:, culled.slots] = culled.near
    assert (~near).mean() > 0.6  # the index culls pairs
    assert (held & near & ~modelled).sum() > 0.1 * (held & near).sum()  # and particles within the pairs
    assert truth[held & ~modelled].min() >= params.new_landmark_gate
    np.testing.assert_allclose(spread(model, 60)[modelled], truth[modelled], rtol=1e-9)
    # Without the cull within the pairs (no points), the same pairs hold the same values where both compute.
    whole_pairs = Candidates(culled.slots, culled.valid, culled.near)
    unculled = spread(slam._model(observations, noise, whole_pairs, version == 2), 60)
    assert np.array_equal(unculled[modelled], spread(model, 60)[modelled])
    assert unculled[~modelled].min() >= params.new_landmark_gate


def two_particles_one_slot(second_landmark_x: float, association: str = "unknown") -> FastSLAM:
    """Two particles at the origin facing +x (FastSLAM 1.0: no pose uncertainty), whose slot 0 holds
    a landmark at (1, 0) in particle 0 and at (``second_landmark_x``, 0) in particle 1, of
    covariance 0.005^2 I, identity 7; the sensor noise is 0.005 m and 0.005 rad."""
    params = dataclasses.replace(EXACT, NPARTICLES=2, version=1, sigmaR=0.005, sigmaB=0.005, association=association)
    slam = FastSLAM(params)
    slam.exists[:, 0] = True
    slam.means[:, 0] = [[1.0, 0.0], [second_landmark_x, 0.0]]
    slam.covariances[:, 0] = 0.005**2 * np.eye(2)
    slam.ids[:, 0] = 7
    slam.reindex()
    return slam


@pytest.mark.parametrize(
    ("second_landmark_x", "kept"),
    [(1.06, False), (1.04, True), (1.02, True)],
)
def test_a_particle_whose_landmark_is_beyond_reach_is_left_out_of_its_pair(second_landmark_x, kept):
    """One observation at range 1 m, bearing 0: at (1, 0) in both particles, so the pair is near by
    the slot's box (x 1 to second_landmark_x). In particle 1 the landmark lies dx = x - 1 away
    along the beam: innovation (-dx, 0), S_00 = 0.005^2 + 0.005^2, so its squared Mahalanobis
    distance is dx^2 / 5e-5: 72 at 6 cm, 32 at 4 cm, 8 at 2 cm. The pair's reach (``_reach``, new-landmark
    gate 16) is 4.99 cm here: the 6 cm one is left out (beyond the gate, as 72 is), the 4 cm one
    modelled although beyond the gate too (the bound is not tight), the 2 cm one modelled."""
    slam = two_particles_one_slot(second_landmark_x)
    observation, noise = np.array([[1.0, 0.0]]), slam.params.observation_noise(None, 1)
    candidates = slam._candidates(observation, noise, 1)
    assert candidates.near.tolist() == [[True]]
    np.testing.assert_allclose(candidates.reach2, [[0.049915**2]], rtol=1e-4)
    rows, ks, columns = slam._modelled(candidates)
    assert rows.tolist() == ([0, 1] if kept else [0]) and ks.tolist() == columns.tolist() == [0] * len(rows)
    expected = (second_landmark_x - 1.0) ** 2 / 5e-5
    model = slam._model(observation, noise, candidates, False)
    assert model.distance2[0, 0, 0] == 0.0
    if kept:
        np.testing.assert_allclose(model.distance2[1, 0, 0], expected, rtol=1e-9)
    else:
        assert model.distance2[1, 0, 0] == np.inf and expected >= slam.params.new_landmark_gate
    # The update decides as it would with the distance: particle 1 matches only at 2 cm, else starts a landmark.
    report = slam.update(observation)
    assert (report.matched, report.new) == ((2, 0) if second_landmark_x == 1.02 else (1, 1))
    assert (report.pairs, report.within_reach, report.modelled) == (1, len(rows), len(rows))  # no facings: no gate


def test_known_association_models_its_slot_beyond_reach():
    """Known association weighs an observation by its own landmark however far: particle 1's landmark
    7, 6 cm off, is modelled although beyond the pair's reach (squared distance 72)."""
    slam = two_particles_one_slot(1.06, association="known")
    observation, noise = np.array([[1.0, 0.0]]), slam.params.observation_noise(None, 1)
    assigned = np.zeros((2, 1), dtype=np.int64)
    model = slam._model(observation, noise, slam._candidates(observation, noise, 1, assigned), False)
    np.testing.assert_allclose(model.distance2[:, 0, 0], [0.0, 72.0], rtol=1e-9)
    # det S = S_00 S_11: range variance 5e-5; bearing variance the landmark's over range^2 plus the sensor's.
    s_11 = 0.005**2 / np.array([1.0, 1.06]) ** 2 + 0.005**2
    np.testing.assert_allclose(model.det[:, 0, 0], 5e-5 * s_11, rtol=1e-9)
    assert slam.update(observation, ids=np.array([7])).matched == 2


def test_association_is_by_mahalanobis_distance_not_by_metres():
    # A well-known landmark (tiny covariance) does not absorb an observation 3 cm away when the
    # sensor's noise is 3 mm: the exercise's 8-10 cm Euclidean threshold would associate it.
    params = dataclasses.replace(EXACT, sigmaR=0.003, sigmaB=0.003)
    slam = FastSLAM(params)
    for _ in range(30):
        slam.update(observe((0, 0, 0), (0.3, 0.0)))
    report = slam.update(observe((0, 0, 0), (0.33, 0.0)))
    assert report.matched == 0 and report.new == 1
    # A fresh, uncertain landmark does take an observation that is as far off in metres.
    fresh = FastSLAM(dataclasses.replace(EXACT, sigmaR=0.02, sigmaB=0.05))
    fresh.update(observe((0, 0, 0), (0.3, 0.0)))
    assert fresh.update(observe((0, 0, 0), (0.33, 0.0))).matched == 1


def test_two_observations_never_update_one_landmark():
    slam = FastSLAM(EXACT)
    slam.update(observe((0, 0, 0), (0.3, 0.0)))
    twins = np.vstack([observe((0, 0, 0), (0.3, 0.0)), observe((0, 0, 0), (0.301, 0.0))])
    report = slam.update(twins)
    assert report.matched == 1
    assert report.ambiguous + report.new == 1  # the second is reported, not silently dropped


def test_association_finds_the_right_landmarks_in_any_order():
    slam = FastSLAM(EXACT)
    a, b = (0.3, 0.1), (-0.2, 0.4)
    slam.update(np.vstack([observe((0, 0, 0), a), observe((0, 0, 0), b)]))
    before = slam.landmarks()[0].copy()
    report = slam.update(np.vstack([observe((0, 0, 0), b), observe((0, 0, 0), a)]))
    assert report.matched == 2 and report.new == 0
    np.testing.assert_allclose(slam.landmarks()[0], before, atol=1e-12)


def test_particles_that_start_landmarks_are_weighed_too():
    params = dataclasses.replace(EXACT, NPARTICLES=2)
    slam = FastSLAM(params)
    slam.update(observe((0, 0, 0), (0.3, 0.0)))
    slam.exists[1] = False  # particle 1 has no map: it must start a new landmark
    slam.update(observe((0, 0, 0), (0.3, 0.0)))
    weights = slam.weights()
    # Particle 0 matched exactly (likelihood at the peak); particle 1 pays the new-landmark price.
    assert weights[0] > weights[1] > 0


def test_weights_never_nan_when_every_likelihood_underflows():
    slam = FastSLAM(dataclasses.replace(EXACT, NPARTICLES=5))
    slam.log_weights[:] = [-1e6, -1e6 - 1, -1e6 - 2, -2e6, -1e6]
    weights = slam.weights()
    assert np.all(np.isfinite(weights)) and weights.sum() == pytest.approx(1.0)
    assert weights[0] == pytest.approx(weights[4])
    assert slam.effective_sample_size() > 1


def test_systematic_resampling_keeps_counts_within_one_of_expectation():
    slam = FastSLAM(dataclasses.replace(EXACT, NPARTICLES=8))
    slam.poses[:, 0] = np.arange(8)
    slam.log_weights = np.log(np.array([0.5, 0.25, 0.125, 0.125, 1e-9, 1e-9, 1e-9, 1e-9]))
    slam.resample()
    counts = np.bincount(slam.poses[:, 0].astype(int), minlength=8)
    assert counts[:4].tolist() == [4, 2, 1, 1]
    np.testing.assert_allclose(slam.weights(), 1 / 8)


def test_resampling_only_below_the_effective_sample_size_threshold():
    slam = FastSLAM(dataclasses.replace(EXACT, NPARTICLES=4, resample_threshold=0.5))
    slam.log_weights = np.log(np.full(4, 0.25))
    assert not slam.update(np.empty((0, 2))).resampled
    slam.log_weights = np.log(np.array([0.97, 0.01, 0.01, 0.01]))
    assert slam.update(np.empty((0, 2))).resampled


def test_tentative_landmarks_seen_once_are_removed_when_missed():
    params = dataclasses.replace(EXACT, view_range=1.0, tentative_limit=2)
    slam = FastSLAM(params)
    slam.update(observe((0, 0, 0), (0.3, 0.0)))  # a spurious one-off
    slam.update(observe((0, 0, 0), (0.0, 0.3)))  # missed once
    report = slam.update(observe((0, 0, 0), (0.0, 0.3)))  # missed twice: removed
    assert report.removed == 1
    np.testing.assert_allclose(slam.landmarks()[0], [[0.0, 0.3]], atol=1e-12)


def test_known_association_uses_identities():
    params = dataclasses.replace(EXACT, association="known")
    slam = FastSLAM(params)
    slam.update(np.vstack([observe((0, 0, 0), (0.3, 0)), observe((0, 0, 0), (0.31, 0))]), ids=np.array([7, 8]))
    report = slam.update(observe((0, 0, 0), (0.3, 0)), ids=np.array([8]))
    assert report.matched == 1
    with pytest.raises(ValueError, match="needs the observations' ids"):
        slam.update(observe((0, 0, 0), (0.3, 0)))


def test_landmark_slots_grow_as_needed():
    slam = FastSLAM(dataclasses.replace(EXACT, view_range=0.0), capacity=2)  # nothing expected, nothing removed
    for k in range(5):
        slam.update(observe((0, 0, 0), (0.2 + 0.1 * k, 0.1 * k)))
    assert len(slam.landmarks()[0]) == 5


@pytest.mark.parametrize(
    "kwargs", [{"NPARTICLES": 0}, {"sigmaX": -1}, {"gate": 20.0}, {"association": "nearest"}, {"resample_threshold": 2}]
)
def test_impossible_filter_parameters(kwargs):
    with pytest.raises(ValueError):
        FastSLAMParams(**kwargs)


def test_fastslam2_draws_poses_from_the_kalman_posterior_of_motion_and_observation():
    # Robot believed at the origin with 5 cm of x-uncertainty from the motion; a landmark known to
    # 1 mm straight ahead at 0.3 m is seen at 0.27 m: the posterior along x is the 1-D Kalman
    # combination of the motion (5 cm) and the observation (1 cm range noise plus the landmark).
    params = FastSLAMParams(
        NPARTICLES=4000,
        sigmaR=0.01,
        sigmaB=0.01,
        observation_scale=0.0,
        inflation=1.0,
        resample_threshold=0,
        version=2,
        view_range=0.0,
        seed=1,
    )
    slam = FastSLAM(params)
    slam.exists[:, 0] = True
    slam.means[:, 0] = (0.3, 0.0)
    slam.covariances[:, 0] = np.eye(2) * 1e-6
    slam.seen[:, 0] = 5
    slam.reindex()
    slam.pose_covariances[:, 0, 0] = 0.05**2
    slam.update(np.array([[0.27, 0.0]]))
    prior, measured = 0.05**2, 0.01**2 + 1e-6
    expected_mean = prior / (prior + measured) * 0.03  # the landmark looks 3 cm nearer: the robot moved on
    expected_std = math.sqrt(prior * measured / (prior + measured))
    assert slam.poses[:, 0].mean() == pytest.approx(expected_mean, abs=3e-4)
    assert slam.poses[:, 0].std() == pytest.approx(expected_std, rel=0.05)
    assert np.allclose(slam.pose_covariances, 0)  # the motion's uncertainty is spent


def test_fastslam2_keeps_more_particles_alive(default_run):
    from mazeslam.pipeline import SlamConfig, slam_on_file

    runs = {
        v: slam_on_file(default_run.log_path, SlamConfig(fastslam=FastSLAMParams(version=v)), progress=False)
        for v in (1, 2)
    }
    assert runs[2].resamplings < 0.6 * runs[1].resamplings


def test_fastslam2_carries_the_spread_fastslam1_draws_for_laser_odometry():
    """Three turning relative motions: FastSLAM 2.0's linearised covariance (before a scan draws
    the poses) matches the spread of FastSLAM 1.0's particles, which draw the same noise."""
    steps = [np.array([1.0, 0.1, 0.4]), np.array([0.8, -0.05, -0.3]), np.array([1.2, 0.0, 0.6])]
    noise = dict(sigmaX=0.05, sigmaTH=0.05, sigmaTH_drive=0.02)
    drawn = FastSLAM(FastSLAMParams(NPARTICLES=20000, version=1, seed=3, **noise), start_pose=(1.0, -1.0, 0.3))
    carried = FastSLAM(FastSLAMParams(NPARTICLES=2, version=2, **noise), start_pose=(1.0, -1.0, 0.3))
    for step in steps:
        drawn.predict_relative(step)
        carried.predict_relative(step)
    assert carried.poses[0] == pytest.approx(drawn.poses.mean(axis=0), abs=0.01)
    assert carried.pose_covariances[0] == pytest.approx(np.cov(drawn.poses.T), abs=2e-4, rel=0.1)


def test_the_report_counts_the_model_the_facing_gate_leaves():
    """One particle, two landmarks at one spot 1 m ahead facing opposite ways (a wall end): the
    observation there, facing back at the robot, is near both slots and within reach of both, and
    the facing gate leaves the model one of them, which it matches."""
    slam = FastSLAM(dataclasses.replace(EXACT, sigmaR=0.005, sigmaB=0.005))
    slam.exists[0, :2] = True
    slam.means[0, :2] = [1.0, 0.0]
    slam.covariances[0, :2] = 0.005**2 * np.eye(2)
    slam.facings[0, :2] = [0.0, math.pi]
    slam.seen[0, :2] = 5
    slam.reindex()
    report = slam.update(np.array([[1.0, 0.0]]), facings=np.array([math.pi]))
    assert (report.pairs, report.within_reach, report.modelled, report.matched) == (2, 2, 1, 1)
    assert slam.seen[0, :2].tolist() == [5, 6]
