import subprocess
import sys

import pytest
from click.testing import CliRunner
from conftest import PROJECT_ROOT
from PIL import Image

from mazeslam.cli.main import main
from mazeslam.data import log, sidecars


def invoke(*args):
    return CliRunner().invoke(main, [str(a) for a in args], catch_exceptions=False)


def test_simulate_writes_log_and_sidecars(tmp_path):
    out = tmp_path / "runs" / "demo.log"
    result = invoke(
        "simulate", "--out", out, "--seed", 4, "--rows", 3, "--cols", 5, "--beams", 120, "--duration", 15, "--quiet"
    )
    assert result.exit_code == 0, result.output
    assert f"wrote {out}" in result.output
    course_log = log.read(out)
    assert course_log.n_beams == 120
    assert sidecars.read_map(sidecars.map_path(out))["maze"]["cols"] == 5
    assert sidecars.truth_path(out).read_text().startswith("t,x,y,theta\n")


def test_info_summarises_a_log(default_run):
    result = invoke("info", default_run.log_path)
    assert result.exit_code == 0
    assert "valid course log" in result.output
    assert "beams per scan    180" in result.output


def test_info_on_a_broken_log_names_the_line_and_exits_2(tmp_path):
    path = tmp_path / "broken.log"
    path.write_text("0.0 0 0 0 -1 -1\n0.1 1 0.5 0.5 zz 0.5\n")
    process = subprocess.run([sys.executable, "-m", "mazeslam.cli", "info", str(path)], capture_output=True, text=True)
    assert process.returncode == 2
    assert f"error: {path}:2: value 'zz' in column 5 is not a number" in process.stderr


def test_info_lenient_reports_skipped_lines(tmp_path):
    path = tmp_path / "broken.log"
    path.write_text("0.0 0 0 0 -1 -1\n0.1 1 0.5 0.5 zz 0.5\n0.2 1 0.5 0.5 0.5 0.5\n")
    result = invoke("info", path, "--lenient")
    assert result.exit_code == 0
    assert "skipped line 2: value 'zz'" in result.output


def test_simulate_rejects_impossible_parameters(tmp_path):
    result = CliRunner().invoke(main, ["simulate", "--out", str(tmp_path / "x.log"), "--beams", "1"])
    assert result.exit_code == 2
    assert "--beams" in result.output


def test_demo_simulates_maps_prints_ate_table_and_writes_plot(tmp_path):
    result = invoke("demo", "--out", tmp_path / "demo", "--quiet")
    assert result.exit_code == 0, result.output
    assert "| dead reckoning " in result.output and "| FastSLAM (mean) " in result.output
    assert (tmp_path / "demo" / "slam" / "slam.png").stat().st_size > 10_000
    trajectory = (tmp_path / "demo" / "slam" / "trajectory.csv").read_text().splitlines()
    assert trajectory[0] == "t,x,y,theta,cov_xx,cov_xy,cov_xtheta,cov_yy,cov_ytheta,cov_thetatheta"
    assert len(trajectory) - 1 == len(log.read(tmp_path / "demo" / "run.log"))


def test_simulate_plot(tmp_path):
    result = invoke("simulate", "--out", tmp_path / "r.log", "--duration", 10, "--plot", tmp_path / "r.png", "--quiet")
    assert result.exit_code == 0, result.output
    assert (tmp_path / "r.png").stat().st_size > 10_000


@pytest.mark.parametrize("command", ["simulate", "info", "demo", "corners", "slam"])
def test_help(command):
    assert invoke(command, "--help").exit_code == 0


def test_corners_command_plots_and_writes_json(default_run, tmp_path):
    result = invoke(
        "corners",
        default_run.log_path,
        "--scan",
        3,
        "--plot",
        tmp_path / "scan.png",
        "--json",
        tmp_path / "corners.json",
    )
    assert result.exit_code == 0, result.output
    assert "sidecar" in result.output  # the beam geometry came from the map sidecar
    assert (tmp_path / "scan.png").stat().st_size > 10_000
    import json

    document = json.loads((tmp_path / "corners.json").read_text())
    course_log = log.read(default_run.log_path)
    assert len(document["scans"]) == int(course_log.is_scan.sum())
    kinds = {o["kind"] for scan in document["scans"] for o in scan["observations"]}
    assert kinds <= {"corner", "wall_end"}
    assert document["parameters"]["max_range"] is None  # infinite: no limit


def test_corners_endpoint_mode_and_animation(tmp_path):
    # A 20 s run (about 25 scans, not the default run's 143): the animation has a frame for each scan.
    run_log = tmp_path / "short.log"
    assert invoke("simulate", "--out", run_log, "--duration", 20, "--quiet").exit_code == 0
    result = invoke("corners", run_log, "--mode", "endpoints", "--animate", tmp_path / "a.gif")
    assert result.exit_code == 0, result.output
    assert "mode             endpoints" in result.output
    assert (tmp_path / "a.gif").read_bytes()[:3] == b"GIF"
    with Image.open(tmp_path / "a.gif") as animation:
        assert animation.n_frames == int(log.read(run_log).is_scan.sum())


def test_corners_refuses_a_scan_that_does_not_exist(default_run, tmp_path):
    process = subprocess.run(
        [
            sys.executable,
            "-m",
            "mazeslam.cli",
            "corners",
            str(default_run.log_path),
            "--scan",
            "100000",
            "--plot",
            str(tmp_path / "x.png"),
        ],
        capture_output=True,
        text=True,
    )
    assert process.returncode == 2
    assert "scan 100000 does not exist" in process.stderr


def test_corners_on_the_exercise_robot_log(course_log_path, tmp_path):
    result = invoke(
        "corners",
        course_log_path,
        "--config",
        PROJECT_ROOT / "configs" / "course.toml",  # its [corners] section
        "--first-beam-angle",
        0,
        "--mount-x",
        0.11,
    )
    assert result.exit_code == 0, result.output
    assert "overridden by first_beam_angle, mount_x" in result.output


def test_info_detects_the_beam_convention_slam_uses_it_and_warns_about_a_wrong_one(course_log_path, tmp_path):
    config = PROJECT_ROOT / "configs" / "course.toml"
    result = invoke("info", course_log_path, "--detect-beams", "--config", config)
    assert result.exit_code == 0, result.output
    best = next(line for line in result.output.splitlines() if line.strip().startswith("best"))
    assert "direction +1" in best and abs(float(best.split("beam 0 at")[1].split("deg")[0])) <= 5
    corner_fastslam = ["--config", config, "--map", "landmarks", "--quiet"]  # faster than the config's grid filter
    result = invoke("slam", course_log_path, *corner_fastslam, "--out", tmp_path / "s")
    assert "beam geometry: detected from the scans: beam 0 at 0 deg, direction +1" in result.output
    assert (tmp_path / "s" / "beam_convention.json").exists()  # the next run reads it
    assert "warning" not in result.output
    assert "left out 5 odometry records" in result.output
    assert "Map sharpness" in result.output
    result = invoke("slam", course_log_path, *corner_fastslam, "--first-beam-angle", -3.14159, "--out", tmp_path / "s")
    assert "warning: with beam 0 at -180 deg" in result.output
    result = invoke("slam", course_log_path, *corner_fastslam, "--first-beam-angle", 0, "--out", tmp_path / "s")
    assert "warning" not in result.output
    assert (tmp_path / "s" / "slam.png").exists()
