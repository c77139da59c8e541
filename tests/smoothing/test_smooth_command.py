"""``mazeslam smooth`` end to end, the optimum beside ``mazeslam slam``, and its errors."""

import json
import shutil
import subprocess
import sys

import numpy as np
import pytest
from click.testing import CliRunner
from conftest import PROJECT_ROOT

from mazeslam.cli.main import main
from mazeslam.data import sidecars
from mazeslam.data.loaded_run import load_run
from mazeslam.evaluation.scoring import score_run
from mazeslam.pipeline import SlamConfig, run_slam
from mazeslam.smoothing.optimum import has_known_optimum, optimum_columns


def invoke(*args):
    return CliRunner().invoke(main, [str(a) for a in args], catch_exceptions=False)


def strict_json(path):
    """The document at ``path``, refusing NaN and infinities (strict JSON)."""

    def refuse(constant):
        raise ValueError(f"{path}: {constant} is not strict JSON")

    return json.loads(path.read_text(), parse_constant=refuse)


def test_smooth_with_known_association_writes_the_slam_outputs(default_run, tmp_path):
    out = tmp_path / "smooth"
    result = invoke("smooth", default_run.log_path, "--out", out)
    assert result.exit_code == 0, result.output
    assert "chi2/dof" in result.output and "Pose NEES at the" in result.output
    assert "| dead reckoning " in result.output and "| batch optimum " in result.output
    _, poses, covariances = sidecars.read_trajectory(out / "trajectory.csv")
    run = load_run(default_run.log_path)
    assert len(poses) == len(run.log)
    scans = np.flatnonzero(run.log.is_scan)
    assert np.all(np.linalg.eigvalsh(covariances[scans]) > 0)  # the information matrix's, at every scan
    document = strict_json(out / "map.json")
    assert document["converged"] and document["dof"] > 0
    assert document["chi2_per_dof"] == pytest.approx(document["chi2"] / document["dof"])
    assert len(document["landmarks"]) == len(document["landmark_covariances"]) == len(document["landmark_ids"])
    ate = {row["estimator"]: row["ate_rmse"] for row in document["ate"]}
    assert ate["batch optimum"] < 0.5 * ate["dead reckoning"]
    assert document["nees"]["count"] == len(scans)
    assert (out / "smooth.png").stat().st_size > 10_000


def test_slam_reports_the_optimum_and_smooth_takes_its_association(default_run, tmp_path):
    result = invoke("slam", default_run.log_path, "--out", tmp_path / "slam", "--quiet")
    assert result.exit_code == 0, result.output
    line = next(line for line in result.output.splitlines() if line.startswith("Batch optimum (known association"))
    assert "FastSLAM/optimum ratio" in line
    filtered = {row["estimator"]: row for row in strict_json(tmp_path / "slam" / "map.json")["ate"]}
    result = invoke(
        "smooth", default_run.log_path, "--association", "from-run", tmp_path / "slam", "--out", tmp_path / "from_run"
    )
    assert result.exit_code == 0, result.output
    assert f"from the run {tmp_path / 'slam'}" in result.output
    document = strict_json(tmp_path / "from_run" / "map.json")
    smoothed = {row["estimator"]: row for row in document["ate"]}
    # Seed 0: 2.4 mm aligned against the filter's 4.4 mm (and 0.65 mm with known association: the
    # filter's map merges the two corners of some wall ends, 1 cm apart, into one landmark).
    assert smoothed["batch optimum"]["aligned_rmse"] < filtered["FastSLAM (mean)"]["aligned_rmse"]
    assert smoothed["batch optimum"]["ate_rmse"] < 0.5 * smoothed["dead reckoning"]["ate_rmse"]


def test_optimum_columns_are_the_filters_ratio_at_its_scored_records(default_run):
    run = load_run(default_run.log_path)
    result = run_slam(run, SlamConfig(), progress=False)
    score = score_run(run, result)
    columns = optimum_columns(run, SlamConfig(), score)
    assert columns["optimum_ratio"] == pytest.approx(score.ate() / columns["optimum_ate_rmse"])
    assert columns["optimum_aligned_ratio"] == pytest.approx(
        score.ate(aligned=True) / columns["optimum_ate_aligned_rmse"]
    )
    assert 0 < columns["optimum_ate_aligned_rmse"] <= columns["optimum_ate_rmse"]
    without_truth = load_run(_log_alone(default_run.log_path, run.path.parent / "elsewhere"))
    assert not has_known_optimum(without_truth)


def _log_alone(log_path, folder):
    """A copy of the log without its sidecars."""
    folder.mkdir(exist_ok=True)
    return shutil.copy(log_path, folder / "alone.log")


def test_known_association_without_truth_is_an_error(default_run, tmp_path):
    log_path = _log_alone(default_run.log_path, tmp_path)
    process = subprocess.run(
        [sys.executable, "-m", "mazeslam.cli", "smooth", str(log_path)],
        capture_output=True,
        text=True,
        check=False,
    )
    assert process.returncode == 2
    assert "--association known needs the truth and map sidecars" in process.stderr
    assert "use --association from-run RUN_DIR" in process.stderr


@pytest.mark.parametrize("args", [["--association", "from-run"], ["--association", "known", "."]])
def test_run_dir_goes_with_from_run_only(default_run, args):
    result = CliRunner().invoke(main, ["smooth", str(default_run.log_path), *args])
    assert result.exit_code == 2
    assert "RUN_DIR goes with --association from-run" in result.output


def test_from_run_on_the_exercise_robot_log(course_log_path, tmp_path):
    options = ["--config", PROJECT_ROOT / "configs" / "course.toml", "--first-beam-angle", 0]
    # the smoother reads a corner map: corner FastSLAM's, not the config's grid filter's
    slam_options = [*options, "--map", "landmarks", "--out", tmp_path / "slam", "--quiet"]
    assert invoke("slam", course_log_path, *slam_options).exit_code == 0
    result = invoke(
        "smooth",
        course_log_path,
        *options,
        "--association",
        "from-run",
        tmp_path / "slam",
        "--out",
        tmp_path / "smooth",
    )
    assert result.exit_code == 0, result.output
    assert "no ground truth beside the log" in result.output
    document = strict_json(tmp_path / "smooth" / "map.json")
    assert document["converged"] and len(document["landmarks"]) > 0
    assert "ate" not in document


def test_from_run_refuses_a_folder_that_is_not_a_slam_run(default_run, tmp_path):
    with pytest.raises(ValueError, match="not a `mazeslam slam` output folder"):
        invoke("smooth", default_run.log_path, "--association", "from-run", tmp_path)


def _one_scan_log(default_run, folder):
    """The default run cut to its first scan record alone, with its true pose and the world's map
    (starting there): a log of one pose, which the optimum places without error."""
    from mazeslam.data import log

    course_log = log.read(default_run.log_path)
    scan = int(np.flatnonzero(course_log.is_scan)[0])
    times, truth = sidecars.read_truth(sidecars.truth_path(default_run.log_path))
    path = folder / "one_scan.log"
    with log.LogWriter(path, course_log.width) as writer:
        writer.write_scan(course_log.times[scan], course_log.values[scan])
    sidecars.write_truth(sidecars.truth_path(path), times[scan : scan + 1], truth[scan : scan + 1])
    world = json.loads(sidecars.map_path(default_run.log_path).read_text())
    world["start_pose"] = truth[scan].tolist()
    sidecars.map_path(path).write_text(json.dumps(world))
    return path


def test_the_optimum_of_a_one_scan_log_leaves_the_ratio_undefined(default_run, tmp_path):
    """Issue 36 item 11: a one-scan log with truth ended in ZeroDivisionError (the optimum's ATE is 0)."""
    from mazeslam.smoothing.optimum import optimum_line

    run = load_run(_one_scan_log(default_run, tmp_path))
    assert has_known_optimum(run)
    score = score_run(run, run_slam(run, SlamConfig(), progress=False))
    columns = optimum_columns(run, SlamConfig(), score)
    assert columns["optimum_ate_rmse"] == columns["optimum_ate_aligned_rmse"] == 0.0
    assert np.isnan(columns["optimum_ratio"]) and np.isnan(columns["optimum_aligned_ratio"])
    assert optimum_line(columns).endswith("ratio undefined (aligned undefined): the optimum has no error")
    result = invoke("slam", run.path, "--out", tmp_path / "slam", "--quiet")
    assert result.exit_code == 0, result.output
    assert "FastSLAM/optimum ratio undefined (aligned undefined): the optimum has no error" in result.output
