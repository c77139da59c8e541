"""The pose graph of whole laser logs: the simulated building (a ring of corridors driven 1.3 times
with bending odometry: the graph closes the loop to below a centimetre of the truth), a log without
loops (the graph is the laser odometry's chain, or within its covariance of it with local matches;
the same twice), and
the first scans of a real CARMEN log (skipped without ../shared/data)."""

import dataclasses

import numpy as np
import pytest
from conftest import SHARED_DATA

from mazeslam.data import log, sidecars
from mazeslam.data.loaded_run import load_run
from mazeslam.evaluation.metrics import absolute_trajectory_error
from mazeslam.pipeline.config import SlamConfig
from mazeslam.posegraph.graph import EdgeKind
from mazeslam.posegraph.laser_graph import laser_pose_graph
from mazeslam.posegraph.params import PoseGraphParams
from mazeslam.registration.scan_matching import ScanMatchParams
from mazeslam.sim.building import simulate_building_log

CONFIG = SlamConfig(scan_matching=ScanMatchParams(enabled=True))


def _building(folder, laps):
    simulated = simulate_building_log(folder / "building.log", laps=laps)
    sidecars.write_truth(sidecars.truth_path(simulated.path), log.read(simulated.path).times, simulated.truth)
    sidecars.write_map(
        sidecars.map_path(simulated.path),
        np.empty((0, 4)),
        np.empty((0, 2)),
        simulated.geometry.to_dict(),
        start_pose=simulated.start_pose.tolist(),
    )
    return load_run(simulated.path)


@pytest.fixture(scope="module")
def building(tmp_path_factory):
    return _building(tmp_path_factory.mktemp("building"), laps=1.3)


def test_the_graph_closes_the_simulated_buildings_loop(building):
    result = laser_pose_graph(building, CONFIG)
    truth = building.truth[result.scan_records]
    odometry = absolute_trajectory_error(result.odometry_poses, truth, align=True)["rmse"]
    ate = absolute_trajectory_error(result.poses, truth, align=True)["rmse"]
    assert ate < 0.02  # the grid filter's best particle: 0.022 to 0.033 m (experiments/carmen_grid)
    assert ate < odometry / 3
    assert result.kept(EdgeKind.CLOSURE) >= 5
    assert result.covariances.shape == (len(result.scan_records), 3, 3)
    assert np.all(np.linalg.eigvalsh(result.covariances[1:]) > 0)


def test_without_loops_the_graph_is_the_odometry_chain_within_its_covariance(tmp_path):
    # A third of a lap: no place is seen twice, so no closure; the local matches may move the
    # poses, but only within the covariance the chain states.
    run = _building(tmp_path, laps=0.3)
    without_local = PoseGraphParams(closures=dataclasses.replace(PoseGraphParams().closures, local_anchors=()))
    result = laser_pose_graph(run, CONFIG, without_local)
    assert result.tried["closure"] == 0 and result.tried["local"] == 0
    np.testing.assert_allclose(result.poses, result.odometry_poses, atol=1e-9)
    with_local = laser_pose_graph(run, CONFIG)
    assert np.array_equal(with_local.poses, laser_pose_graph(run, CONFIG).poses)  # deterministic
    assert with_local.tried["closure"] == 0
    difference = with_local.poses[1:] - with_local.odometry_poses[1:]
    nees = np.einsum("si,sij,sj->s", difference, np.linalg.inv(result.covariances[1:]), difference)
    assert np.all(nees < 16.27)  # chi-square 99.9 % for 3 degrees of freedom
    traces = np.trace(result.covariances[1:, :2, :2], axis1=1, axis2=2)
    assert traces[-1] > traces[0]


def test_the_first_scans_of_a_carmen_log_beat_the_laser_odometry(tmp_path):
    carmen = SHARED_DATA / "carmen" / "freiburg-101-corrected.log.gz"
    if not carmen.exists():
        pytest.skip(f"CARMEN log not found at {carmen} (the shared data folder is absent)")
    from mazeslam.data.carmen import import_carmen

    course = tmp_path / "freiburg-101.log"
    import_carmen(carmen, course)
    run = load_run(course)
    last = np.flatnonzero(run.log.is_scan)[60]  # about 180 s: round the building's corridor
    keep = np.arange(len(run.log)) <= last
    cut = dataclasses.replace(
        run.log, times=run.log.times[keep], flags=run.log.flags[keep], values=run.log.values[keep]
    )
    run = dataclasses.replace(run, log=cut, truth=run.truth[keep])
    result = laser_pose_graph(run, CONFIG)
    reference = run.truth[result.scan_records]
    ate = absolute_trajectory_error(result.poses, reference, align=True)["rmse"]
    assert ate < 0.05  # the reference poses themselves carry centimetres of error
    assert ate < absolute_trajectory_error(result.odometry_poses, reference, align=True)["rmse"]
    assert result.kept(EdgeKind.CLOSURE) >= 5
