"""Issue 36 item 2: a log run with settings that do not fit it stops with one line in words (what went
bad, where, the settings to check), never a numpy error or RuntimeWarning on the way.

The reproducer is an MRCLAM log run on the defaults (measured for scans: sigmaR = sigmaB = 0, the
corners' own covariances); a small landmark log of the same kind stands in for it, and the real one
is checked too where the shared data is present."""

import math

import numpy as np
import pytest
from conftest import PROJECT_ROOT, SHARED_DATA

from mazeslam.data import log
from mazeslam.fastslam import ekf
from mazeslam.fastslam.filter import FastSLAM, FastSLAMParams, FilterDivergence
from mazeslam.pipeline import SlamConfig, load_slam_config, slam_on_file
from mazeslam.pipeline.fastslam_run import run_fastslam

#: Landmarks (x, y, metres) around a robot driving an arc from the origin.
LANDMARKS = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0], [1.5, 1.5]])
#: Landmark records carry no covariance: these noise settings are their whole noise.
LANDMARK_NOISE = dict(sigmaR=0.01, sigmaB=0.01, observation_scale=0.0)

pytestmark = pytest.mark.filterwarnings("error")  # a RuntimeWarning on the way fails the test


def landmark_log(path, steps: int = 60, seed: int = 0):
    """A log like an imported MRCLAM one: odometry every 0.1 s along an arc, and every other record
    range and bearing (1 cm, 0.01 rad of noise) to the ``LANDMARKS`` within 2.5 m and 1.2 rad."""
    rng = np.random.default_rng(seed)
    pose = np.zeros(3)
    with log.LogWriter(path, beams=3) as writer:
        for k in range(1, steps + 1):
            distance, turn = 0.05, 0.1
            heading = pose[2] + turn / 2
            pose = pose + [distance * math.cos(heading), distance * math.sin(heading), turn]
            writer.write_odometry(0.1 * k, distance + rng.normal(0, 0.002), turn + rng.normal(0, 0.005))
            if k % 2:
                continue
            for identity, (x, y) in enumerate(LANDMARKS):
                rho = math.hypot(x - pose[0], y - pose[1])
                bearing = math.remainder(math.atan2(y - pose[1], x - pose[0]) - pose[2], 2 * math.pi)
                if rho < 2.5 and abs(bearing) < 1.2:
                    writer.write_landmark(0.1 * k, identity, rho + rng.normal(0, 0.01), bearing + rng.normal(0, 0.01))
    return path


@pytest.fixture(scope="module")
def landmarks(tmp_path_factory):
    return log.read(landmark_log(tmp_path_factory.mktemp("landmarks") / "landmarks.log"))


def first_landmark_line(course_log) -> int:
    return int(course_log.line_numbers[np.flatnonzero(course_log.is_landmark)[0]])


@pytest.mark.parametrize("version", [1, 2])
@pytest.mark.parametrize("association", ["unknown", "known"])
def test_landmark_log_on_the_scan_defaults_is_refused_before_any_work(landmarks, version, association):
    params = FastSLAMParams(version=version, association=association)  # sigmaR = sigmaB = 0: scans' noise
    with pytest.raises(ValueError) as error:
        run_fastslam(landmarks, params, progress=False)
    message = str(error.value)
    assert f"landmarks.log:{first_landmark_line(landmarks)} " in message
    assert f"this log's {int(landmarks.is_landmark.sum())} landmark observations" in message
    assert "[fastslam] sigmaR and sigmaB are their whole noise, and they are 0 and 0 here" in message
    assert "--config configs/mrclam.toml" in message


def test_the_landmark_log_runs_with_noise_that_fits_it(landmarks):
    result = run_fastslam(landmarks, FastSLAMParams(**LANDMARK_NOISE, seed=1), progress=False)
    assert np.isfinite(result.mean_poses).all() and len(result.landmarks) == len(LANDMARKS)


@pytest.mark.parametrize(
    "noise, line, what",
    [
        # The squares of the noise vanish: the observation noise itself is singular.
        (dict(sigmaR=1e-100, sigmaB=1e-100), "first", "the observation noise diag(sigmaR^2, sigmaB^2) is singular"),
        # The noise is positive, but a new landmark's covariance G R G^T underflows.
        (dict(sigmaR=1e-160, sigmaB=1.0), "first", "a new landmark's covariance is not positive definite"),
        # Runs for a while, until the pose's covariance collapses onto observations this precise.
        (dict(sigmaR=1e-60, sigmaB=1e-60), 7, "an innovation covariance (H P H^T + R) is not positive definite"),
    ],
)
def test_settings_that_do_not_fit_stop_in_words_where_the_numbers_go_bad(landmarks, noise, line, what):
    params = FastSLAMParams(**{**LANDMARK_NOISE, **noise}, association="known", likelihood_exponent=1.0)
    with pytest.raises(FilterDivergence) as error:
        run_fastslam(landmarks, params, progress=False)
    line = first_landmark_line(landmarks) if line == "first" else line
    message = str(error.value)
    assert message.startswith(f"{landmarks.source}:{line} (t ")
    assert f"FastSLAM diverged: {what}" in message
    assert f"sigmaR = {noise['sigmaR']:g}, sigmaB = {noise['sigmaB']:g}" in message
    assert "association ('known')" in message and "--config configs/mrclam.toml" in message
    assert "\n" not in message


def test_slam_on_the_landmark_log_file_says_which_config_it_wants(landmarks):
    with pytest.raises(ValueError, match="a log imported from MRCLAM wants --config configs/mrclam.toml"):
        slam_on_file(landmarks.source, progress=False)


def test_slam_on_file_takes_the_path_of_a_config(landmarks, tmp_path):
    """Issue 36 item 11: ``slam_on_file(log, "configs/fastslam.toml")`` (a path, not a config) ended in
    AttributeError. A path is read as the config file; anything else is a TypeError saying what is wanted."""
    from mazeslam.data.loaded_run import load_run
    from mazeslam.pipeline import run_slam

    config = tmp_path / "landmarks.toml"
    config.write_text("[fastslam]\nsigmaR = 0.01\nsigmaB = 0.01\nobservation_scale = 0.0\nseed = 1\n")
    for given in (config, str(config)):
        result = slam_on_file(landmarks.source, given, progress=False)
        assert result.updates == int(np.unique(landmarks.times[landmarks.is_landmark]).size)
        assert np.isfinite(result.mean_poses).all()
    with pytest.raises(TypeError, match="config must be a SlamConfig or the path of its TOML file, got int"):
        slam_on_file(landmarks.source, 3, progress=False)
    with pytest.raises(TypeError, match=r"run_slam takes a LoadedRun .*for a log file: slam_on_file\(path\)"):
        run_slam(landmarks.source, config)
    assert run_slam(load_run(landmarks.source), config, progress=False).updates == result.updates


def test_an_imported_mrclam_log_without_its_config(tmp_path):
    """The issue's reproducer on the real data: `mazeslam import mrclam ... --robot 1`, then FastSLAM
    on the defaults instead of configs/mrclam.toml (without a config, `mazeslam slam` and
    `slam_on_file` run that one: tests/pipeline/test_log_kinds.py)."""
    dataset = SHARED_DATA / "mrclam" / "MRCLAM_Dataset6"
    if not dataset.exists():
        pytest.skip(f"MRCLAM data not found at {dataset} (the shared data folder is absent)")
    from mazeslam.data.mrclam import import_mrclam

    out = tmp_path / "mrclam1.log"
    import_mrclam(dataset, 1, out)
    with pytest.raises(ValueError) as error:
        slam_on_file(out, SlamConfig(), progress=False)
    assert str(error.value).startswith(f"{out}:77 (t 1248444189.599 s): this log's 1534 landmark observations")
    assert "--config configs/mrclam.toml" in str(error.value)
    config = load_slam_config(PROJECT_ROOT / "configs" / "mrclam.toml")
    assert config.fastslam.sigmaR > 0 and config.fastslam.sigmaB > 0  # the config the message names fits


def test_params_need_an_observation_noise():
    with pytest.raises(ValueError, match="sigmaR and sigmaB must be positive unless"):
        FastSLAMParams(sigmaR=0.01, sigmaB=0.0, observation_scale=0.0)
    for name in ("sigmaR", "sigmaB", "observation_scale"):
        with pytest.raises(ValueError, match=f"{name} must be >= 0 and finite"):
            FastSLAMParams(**{name: math.inf})
    with pytest.raises(ValueError, match="new_landmark_gate"):
        FastSLAMParams(new_landmark_gate=math.inf)


# -- the checks one by one, on a filter whose state is broken by hand ----------------------------------


def filter_with_a_landmark(version: int, association: str = "unknown") -> FastSLAM:
    """A filter of 8 particles that has mapped one landmark 1 m ahead and moved a little."""
    params = FastSLAMParams(NPARTICLES=8, **LANDMARK_NOISE, version=version, association=association)
    slam = FastSLAM(params)
    slam.update(np.array([[1.0, 0.0]]), ids=np.array([0]))
    slam.predict(0.01, 0.0)
    return slam


@pytest.mark.parametrize("version", [1, 2])
@pytest.mark.parametrize("association", ["unknown", "known"])
def test_a_landmark_covariance_gone_bad_is_named(version, association):
    slam = filter_with_a_landmark(version, association)
    slam.covariances[:, 0] = [[1e-4, 2e-4], [2e-4, 1e-4]]  # symmetric, not positive definite
    slam.reindex()
    with pytest.raises(FilterDivergence, match=r"is not positive definite; check \[fastslam\]'s observation noise"):
        slam.update(np.array([[0.99, 0.0]]), ids=np.array([0]))


@pytest.mark.parametrize("version", [1, 2])
def test_a_pose_or_weight_gone_bad_is_named(version):
    slam = filter_with_a_landmark(version)
    slam.poses[3, 0] = np.nan
    with pytest.raises(FilterDivergence, match="FastSLAM diverged: a particle's pose is not finite"):
        slam.update(np.array([[0.99, 0.0]]))
    slam = filter_with_a_landmark(version)
    slam.log_weights[2] = np.inf
    with pytest.raises(FilterDivergence, match="FastSLAM diverged: the particle weights are not finite"):
        slam.update(np.array([[0.99, 0.0]]))


def test_observations_and_motion_must_be_finite():
    slam = filter_with_a_landmark(2)
    with pytest.raises(ValueError, match="observations must be finite"):
        slam.update(np.array([[np.nan, 0.0]]))
    with pytest.raises(ValueError, match="an odometry increment must be finite"):
        slam.predict(math.inf, 0.0)
    with pytest.raises(ValueError, match="a relative motion must be finite"):
        slam.predict_relative([0.0, np.nan, 0.0])


def test_an_observations_own_covariance_gone_bad_is_named():
    slam = FastSLAM(FastSLAMParams(NPARTICLES=4))  # the defaults: the observations' own covariances
    with pytest.raises(FilterDivergence, match="an observation's own covariance .* is not positive definite"):
        slam.update(np.array([[1.0, 0.0]]), covariances=np.zeros((1, 2, 2)))


@pytest.mark.parametrize("batch", [3, ekf.ENTRYWISE_FROM])  # batched matmul, and entry by entry
def test_ekf_update_refuses_a_singular_innovation_covariance_before_inverting_it(batch):
    mean, covariance = np.zeros((batch, 2)), np.tile(np.eye(2), (batch, 1, 1))
    residual, jacobian = np.zeros((batch, 2)), np.tile(np.eye(2), (batch, 1, 1))
    covariance[-1] = 0.0  # with no noise, the last S = H P H^T + R is zero
    with pytest.raises(ekf.NotPositiveDefinite, match="not positive definite"):
        ekf.update(mean, covariance, residual, jacobian, np.zeros((2, 2)))
    covariance[-1] = np.nan
    with pytest.raises(ekf.NotPositiveDefinite):
        ekf.update(mean, covariance, residual, jacobian, 1e-4 * np.eye(2))
    covariance[-1] = np.eye(2)
    new_mean, new_covariance, _ = ekf.update(mean, covariance, residual, jacobian, 1e-4 * np.eye(2))
    assert np.isfinite(new_covariance).all() and np.all(np.linalg.eigvalsh(new_covariance) > 0)
