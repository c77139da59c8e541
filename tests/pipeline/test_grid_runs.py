"""The grid filter through the one pipeline on a simulated building: ``mazeslam slam`` with
``[map] kind = "grid"`` (the map_server map, the trajectory with its covariance, the errors), the
Python API choosing the filter the config names, and the loop it closes where corner FastSLAM does not."""

import json

import numpy as np
import pytest
from click.testing import CliRunner
from conftest import PROJECT_ROOT

from mazeslam.cli.main import main
from mazeslam.core.config import with_settings
from mazeslam.data import log, sidecars
from mazeslam.data.loaded_run import load_run
from mazeslam.data.map_io import OCCUPIED, read_map
from mazeslam.pipeline import MapKind, SlamConfig, load_slam_config, run_slam, slam_on_file
from mazeslam.sim.building import simulate_building_log


@pytest.fixture(scope="module")
def building(tmp_path_factory):
    folder = tmp_path_factory.mktemp("building")
    simulated = simulate_building_log(folder / "building.log")  # with its truth and map sidecars
    config = folder / "grid.toml"
    config.write_text('[map]\nkind = "grid"\n\n[grid]\nparticles = 8\nmotion = "wheels"\n')
    return simulated, config


def test_slam_with_the_grid_filter_writes_a_map_server_map_and_closes_the_loop(building, tmp_path):
    simulated, config = building
    out = tmp_path / "out"
    result = CliRunner().invoke(
        main, ["slam", str(simulated.path), "--config", str(config), "--out", str(out), "--quiet"]
    )
    assert result.exit_code == 0, result.output
    assert (out / "slam.png").stat().st_size > 10_000  # the map with the paths and particles
    occupancy = read_map(out / "occupancy.yaml")
    assert (occupancy.states == OCCUPIED).sum() > 500 and occupancy.resolution > 0
    times, poses, covariances = sidecars.read_trajectory(out / "trajectory.csv")
    assert len(poses) == len(simulated.truth) and np.all(np.linalg.eigvalsh(covariances[-10:]) >= -1e-12)
    document = json.loads((out / "map.json").read_text())
    errors = {row["estimator"]: row for row in document["ate"]}
    assert errors["grid filter (mean)"]["aligned_rmse"] < 0.1 < errors["dead reckoning"]["aligned_rmse"]
    assert document["nees"]["count"] > 0
    assert document["kind"] == "grid"
    assert document["nis"]["count"] > 0.9 * document["processed_scans"]  # every matched scan
    assert "Uncertainty: motion NIS of" in result.output


def test_corner_fastslam_does_not_close_that_loop(building):
    simulated, _ = building
    run = load_run(simulated.path)
    result = run_slam(run, SlamConfig(), progress=False)
    final_error = np.hypot(*(result.mean_poses[-1, :2] - simulated.truth[-1, :2]))
    assert final_error > 0.5  # corridors without corners: the corners give the filter nothing to hold on to


def test_the_map_option_picks_the_filter_and_the_particles_go_to_the_one_that_runs(building, tmp_path):
    simulated, config = building  # a config whose [map] kind is "grid"
    options = ["slam", str(simulated.path), "--config", str(config), "--quiet", "--particles", "3", "--seed", "2"]
    result = CliRunner().invoke(main, [*options, "--out", str(tmp_path / "grid")])
    assert result.exit_code == 0, result.output
    assert "grid filter: 3 particles" in result.output
    assert json.loads((tmp_path / "grid" / "map.json").read_text())["parameters"]["grid"]["seed"] == 2
    result = CliRunner().invoke(main, [*options, "--map", "landmarks", "--out", str(tmp_path / "corners")])
    assert result.exit_code == 0, result.output
    assert "FastSLAM: 3 particles" in result.output


@pytest.mark.slow
def test_animate_draws_the_grid_growing(building, tmp_path, monkeypatch):
    monkeypatch.setattr("mazeslam.cli.slam.ANIMATION_FRAMES", 30)  # fewer frames to draw; still one every few scans
    simulated, config = building
    options = ["slam", str(simulated.path), "--config", str(config), "--quiet", "--particles", "2", "--animate"]
    result = CliRunner().invoke(main, [*options, "--out", str(tmp_path)])
    assert result.exit_code == 0, result.output
    assert "corner FastSLAM only" not in result.output
    animation = next(tmp_path.glob("slam.*[fg4]"))  # slam.gif, or slam.mp4 where ffmpeg is installed
    assert animation.suffix in (".gif", ".mp4") and animation.stat().st_size > 10_000
    if animation.suffix == ".gif":
        from PIL import Image

        with Image.open(animation) as image:
            assert image.n_frames > 20  # one frame every few scans, not one picture


def test_the_python_api_runs_the_filter_the_config_names(building):
    """``slam_on_file`` with configs/carmen.toml (``[map] kind = "grid"``) runs the grid filter, with
    configs/fastslam.toml corner FastSLAM: the same entry, the same result type."""
    simulated, _ = building
    carmen = with_settings(load_slam_config(PROJECT_ROOT / "configs" / "carmen.toml"), {"grid.particles": 4})
    result = slam_on_file(simulated.path, carmen, progress=False)
    assert result.kind == MapKind.GRID and result.grid is not None and result.filter_name == "grid filter"
    assert result.mean_poses.shape == (len(simulated.truth), 3) and result.nis_dof == 3
    np.testing.assert_array_equal(result.estimated_records, np.flatnonzero(log.read(simulated.path).is_scan))
    corners = slam_on_file(simulated.path, load_slam_config(PROJECT_ROOT / "configs" / "fastslam.toml"), progress=False)
    assert corners.kind == MapKind.LANDMARKS and corners.grid is None and len(corners.landmarks) > 0


def test_corner_fastslam_options_under_the_grid_filter_are_said_to_do_nothing(building, tmp_path):
    simulated, config = building
    options = ["slam", str(simulated.path), "--config", str(config), "--quiet", "--particles", "2", "--version", "1"]
    result = CliRunner().invoke(main, [*options, "--out", str(tmp_path)])
    assert result.exit_code == 0, result.output
    assert "--version set corner FastSLAM's [fastslam]; the grid filter runs" in result.output
