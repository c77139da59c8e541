"""``mazeslam smooth`` on a laser log: the pose graph of a simulated building (a ring of corridors
driven 1.3 times with odometry that bends), against its truth and beside the grid filter."""

import numpy as np
import pytest
from click.testing import CliRunner
from test_smooth_command import strict_json

from mazeslam.cli.main import main
from mazeslam.core.geometry import relative
from mazeslam.data import log, sidecars
from mazeslam.evaluation.metrics import absolute_trajectory_error
from mazeslam.gridslam import GridSlamParams, run_grid_slam
from mazeslam.posegraph.params import PoseGraphParams
from mazeslam.sim.building import simulate_building_log


def invoke(*args):
    return CliRunner().invoke(main, [str(a) for a in args], catch_exceptions=False)


@pytest.fixture(scope="module")
def smoothed(tmp_path_factory):
    """The simulated building and the folder `mazeslam smooth` wrote for it (no config: the log's kind
    picks configs/carmen.toml, a grid config, so the pose graph runs)."""
    folder = tmp_path_factory.mktemp("laser_smooth")
    simulated = simulate_building_log(folder / "building.log")
    result = invoke("smooth", simulated.path, "--out", folder / "smooth")
    assert result.exit_code == 0, result.output
    return simulated, folder / "smooth", result.output


def test_the_graph_closes_the_loop_better_than_the_grid_filter(smoothed):
    simulated, out, output = smoothed
    course_log = log.read(simulated.path)
    scans = np.flatnonzero(course_log.is_scan)
    truth = simulated.truth[scans]
    graph_poses = sidecars.read_trajectory(out / "trajectory.csv")[1][scans]
    grid = run_grid_slam(course_log, simulated.geometry, simulated.start_pose, GridSlamParams(particles=8))
    graph_ate = absolute_trajectory_error(graph_poses, truth, align=True)["rmse"]
    assert graph_ate <= absolute_trajectory_error(grid.best_poses, truth, align=True)["rmse"]
    assert graph_ate < 0.05  # 5 cm cells, 1 cm range noise
    document = strict_json(out / "map.json")
    assert document["graph"]["nodes"] == len(scans) and document["graph"]["edges"]["closure"] > 0
    assert document["graph"]["kept_by_solve"]["closure"] > 0
    # NEES at every scan (but the first where the solve holds it with no covariance)
    assert document["nees"]["count"] >= len(scans) - 1 and "Pose NEES at the scans" in output
    # The simulated laser has no heading drift: the estimate is 0 within its spread, which the loops
    # make much narrower than the prior's.
    drift, spread = document["heading_drift_rad_per_m"], document["heading_drift_sigma_rad_per_m"]
    assert 0 < spread < 0.5 * PoseGraphParams().solve.drift_sigma and abs(drift) < 3 * spread
    assert "Heading drift of the scan matches" in output


def test_the_outputs_are_a_slam_runs(smoothed):
    simulated, out, output = smoothed
    times, poses, covariances = sidecars.read_trajectory(out / "trajectory.csv")
    assert len(poses) == len(log.read(simulated.path)) and np.isfinite(covariances).all()
    assert (out / "occupancy.pgm").stat().st_size > 10_000 and (out / "occupancy.yaml").exists()
    assert (out / "smooth.png").stat().st_size > 10_000 and (out / "trajectory.tum").exists()
    assert "settings: configs/carmen.toml, as building.log is a simulated building" in output
    assert "loop closures" in output and "| batch optimum " in output


def test_the_relation_metric_reads_its_output(smoothed, tmp_path):
    simulated, out, _ = smoothed
    times = log.read(simulated.path).times
    pairs = [(k, k + 40) for k in range(0, len(times) - 40, 25)]
    motions = [relative(simulated.truth[a], simulated.truth[b]) for a, b in pairs]
    relations = tmp_path / "building.relations"
    relations.write_text(
        "".join(f"{times[a]} {times[b]} {m[0]} {m[1]} 0 0 0 {m[2]}\n" for (a, b), m in zip(pairs, motions))
    )
    result = invoke("relations", out, relations)
    assert result.exit_code == 0, result.output
    assert f"{len(pairs)} relations" in result.output


def test_the_grid_filters_report_gives_its_ratio_to_the_graph(smoothed, tmp_path, monkeypatch):
    simulated, out, _ = smoothed
    options = ["--particles", 8, "--quiet"]
    result = invoke("slam", simulated.path, *options, "--optimum", out, "--out", tmp_path / "slam")
    assert result.exit_code == 0, result.output
    assert "Batch optimum (pose graph of the scans, loop closures)" in result.output
    assert "grid filter/optimum ratio" in result.output
    assert strict_json(tmp_path / "slam" / "map.json")["optimum"]["optimum_ratio"] > 0
    monkeypatch.chdir(tmp_path)  # runs/building/smooth/ does not exist under it
    result = invoke("slam", simulated.path, *options, "--out", tmp_path / "slam2")
    assert result.exit_code == 0, result.output
    assert f"No pose graph of this log to set the grid filter beside: `mazeslam smooth {simulated.path}`" in (
        result.output.replace("\n", " ")
    )


def test_the_smooth_run_of_another_log_is_refused(smoothed, tmp_path):
    simulated, out, _ = smoothed
    other = simulate_building_log(tmp_path / "other.log", laps=0.2)
    result = CliRunner().invoke(main, ["slam", str(other.path), "--optimum", str(out), "--out", str(tmp_path / "s")])
    assert result.exit_code != 0 and "grid SLAM" not in result.output  # refused before the filter runs
    assert f"the smooth run of {simulated.path}, not of {other.path}" in str(result.exception)


def test_the_drift_line_says_whether_the_loops_decided_the_drift():
    from mazeslam.cli.smooth_laser import drift_line

    assert "taken out" in drift_line(-0.000245, 0.000107, 0.005)  # edmonton's: the loops decide it
    assert "-0.245 +/- 0.107 mrad per metre" in drift_line(-0.000245, 0.000107, 0.005)
    assert "no loop decides it" in drift_line(0.0, 0.0049, 0.005)  # a chain: the prior's spread
    assert "not estimated" in drift_line(0.0, 0.0, 0.0)
