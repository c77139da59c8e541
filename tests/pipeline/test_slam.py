"""FastSLAM over whole simulated logs, against ground truth."""

import dataclasses

import numpy as np
import pytest

from mazeslam import simulate
from mazeslam.core.beams import BeamGeometry, SensorOverrides
from mazeslam.core.motion import dead_reckoning
from mazeslam.data import log, sidecars
from mazeslam.evaluation.metrics import absolute_trajectory_error, align_se2, apply_se2, map_error
from mazeslam.pipeline import SlamConfig, slam_on_file
from mazeslam.sim.laser import LaserParams
from mazeslam.sim.simulator import SimulationConfig


def errors(run_result, slam_result):
    _, truth = sidecars.read_truth(run_result.truth_path)
    world = sidecars.read_map(run_result.map_path)
    reckoned = dead_reckoning(log.read(run_result.log_path), world["start_pose"])
    return {
        "slam": absolute_trajectory_error(slam_result.mean_poses, truth)["rmse"],
        "slam_aligned": absolute_trajectory_error(slam_result.mean_poses, truth, align=True)["rmse"],
        "reckoning": absolute_trajectory_error(reckoned, truth)["rmse"],
        "reckoning_aligned": absolute_trajectory_error(reckoned, truth, align=True)["rmse"],
        "map": map_error(slam_result.landmarks, world["corners"]),
        "map_aligned": map_error(
            apply_se2(align_se2(slam_result.mean_poses, truth), slam_result.landmarks), world["corners"]
        ),
    }


def test_default_run_beats_dead_reckoning_and_maps_the_corners(default_run):
    result = slam_on_file(default_run.log_path, progress=False)
    e = errors(default_run, result)
    assert e["slam"] < 0.03
    assert e["slam"] <= e["reckoning"] / 3  # the bar, on the default run and filter seed
    assert e["slam_aligned"] < 0.5 * e["reckoning_aligned"]
    assert e["map"]["rmse"] < 0.03
    assert e["map"]["precision"] >= 0.9  # landmarks are real corners, not clutter
    assert len(result.mean_poses) == len(log.read(default_run.log_path))


def test_same_seed_same_estimate(default_run):
    config = SlamConfig(fastslam=dataclasses.replace(SlamConfig().fastslam, NPARTICLES=20))
    first = slam_on_file(default_run.log_path, config, progress=False)
    again = slam_on_file(default_run.log_path, config, progress=False)
    np.testing.assert_array_equal(first.mean_poses, again.mean_poses)


@pytest.fixture(scope="module")
def mounted_run(tmp_path_factory):
    config = dataclasses.replace(SimulationConfig(), laser=LaserParams(geometry=BeamGeometry(mount_x=0.04)))
    return simulate(tmp_path_factory.mktemp("mounted") / "run.log", config=config, seed=0, progress=False)


def test_the_sensor_mounting_offset_is_part_of_the_measurement_model(mounted_run):
    # The exercise leaves CAMERA_POS_DX out; here the sidecar's mount_x reaches the observations.
    handled = errors(mounted_run, slam_on_file(mounted_run.log_path, progress=False))
    ignored_config = SlamConfig(sensor=SensorOverrides(mount_x=0.0))
    ignored = errors(mounted_run, slam_on_file(mounted_run.log_path, ignored_config, progress=False))
    assert handled["map"]["precision"] >= 0.9
    assert ignored["map"]["precision"] < 0.5  # ignoring it smears each corner into several landmarks
    # The map's shape (after the best rigid alignment: the offset bends the map, a drift of the whole
    # frame is the odometry's) is much sharper with the offset handled.
    assert handled["map_aligned"]["rmse"] < min(0.01, 0.5 * ignored["map_aligned"]["rmse"])
    assert handled["slam"] < ignored["slam"]


def test_known_association_names_corners_from_the_truth(default_run):
    config = SlamConfig(fastslam=dataclasses.replace(SlamConfig().fastslam, association="known"))
    result = slam_on_file(default_run.log_path, config, progress=False)
    e = errors(default_run, result)
    assert e["map"]["precision"] == 1.0  # every landmark is a true corner, each mapped once
    slam = result.filter
    best = slam.best_particle()
    identities = slam.ids[best][slam.exists[best]]
    assert len(set(identities.tolist())) == len(identities) and identities.min() >= 0
    assert e["slam"] < 0.03


def test_known_association_without_truth_is_refused(tmp_path, default_run):
    import shutil

    copy = tmp_path / "copy.log"
    shutil.copy(default_run.log_path, copy)
    config = SlamConfig(fastslam=dataclasses.replace(SlamConfig().fastslam, association="known"))
    with pytest.raises(ValueError, match="needs the truth and map sidecars"):
        slam_on_file(copy, config, progress=False)


def test_the_written_out_default_config_is_the_defaults_in_code():
    from conftest import PROJECT_ROOT

    from mazeslam.pipeline import SlamConfig, load_slam_config

    written = load_slam_config(PROJECT_ROOT / "configs" / "fastslam.toml")
    assert written.fastslam == SlamConfig().fastslam
    assert written.scan_matching == SlamConfig().scan_matching
