"""Sweeps: grid expansion, resuming after a kill, the same seeds giving the same table, Dask."""

import dataclasses
import json
import signal
import subprocess
import sys
import time

import pandas as pd
import pytest
from conftest import PROJECT_ROOT

from mazeslam.core.config import ConfigError
from mazeslam.sweeps.runner import RESULTS, execute_run, load_sweep, optimum_key, run_sweep, summarise

TIMING = ["slam_seconds", "seconds_per_record"]


def write_sweep(folder, seeds=(0, 1), particles=(5, 20), duration=12.0, extra=""):
    path = folder / "s.toml"
    path.write_text(
        f'name = "t"\nseeds = {list(seeds)}\nduration = {duration}\n{extra}\n[grid]\n'
        f'"slam.fastslam.NPARTICLES" = {list(particles)}\n"sim.laser.beams" = [90]\n'
    )
    return path


def test_grid_expands_over_every_combination_and_seed(tmp_path):
    sweep = load_sweep(write_sweep(tmp_path, seeds=(0, 1, 2), particles=(5, 20)))
    runs = sweep.runs()
    assert len(runs) == 6
    assert {r["settings"]["slam.fastslam.NPARTICLES"] for r in runs} == {5, 20}


@pytest.mark.parametrize(
    "grid_line, message",
    [
        ('"slam.fastslam.particles" = [5]', "no setting 'particles'"),
        ('"filter.NPARTICLES" = [5]', "must start with 'sim.' or 'slam.'"),
        ('"sim.laser.beams" = 90', "non-empty lists"),
        ('"slam.grid.particles" = [5, 30]', "a setting of the grid filter, but every run maps landmarks"),
        ('"slam.map.kind" = ["grid"]\n"slam.fastslam.NPARTICLES" = [5, 30]', "a setting of the FastSLAM, but every"),
    ],
)
def test_bad_sweep_files_are_refused(tmp_path, grid_line, message):
    path = tmp_path / "bad.toml"
    path.write_text(f"seeds = [0]\n[grid]\n{grid_line}\n")
    with pytest.raises(ConfigError, match=message):
        load_sweep(path)


def test_same_seeds_same_table_in_parallel_or_not(tmp_path):
    sweep = load_sweep(write_sweep(tmp_path))
    serial = run_sweep(sweep, tmp_path / "a", workers=1, progress=False).table.drop(columns=TIMING)
    parallel = run_sweep(sweep, tmp_path / "b", workers=2, progress=False).table.drop(columns=TIMING)
    pd.testing.assert_frame_equal(serial, parallel)
    assert (tmp_path / "a" / "results.parquet").exists() and (tmp_path / "a" / "summary.md").exists()
    summary = summarise(serial.assign(slam_seconds=0.0, seconds_per_record=0.0), ["slam.fastslam.NPARTICLES"])
    assert list(summary["runs"]) == [2, 2]


def test_runs_of_one_log_and_noise_share_one_optimum_and_give_the_same_rows(tmp_path):
    """The batch optimum does not depend on the particle count: one per log and noise setting,
    computed once, and each row is what the run gives on its own (simulating and smoothing itself)."""
    sweep = load_sweep(write_sweep(tmp_path, seeds=(0,), particles=(5, 20), duration=8.0))
    runs = sweep.runs()
    assert len({optimum_key(sweep, run) for run in runs}) == 1
    table = run_sweep(sweep, tmp_path / "out", workers=1, progress=False).table.drop(columns=TIMING)
    alone = pd.DataFrame([execute_run(sweep, run) for run in runs]).drop(columns=TIMING)
    assert table["optimum_ratio"].notna().all()
    pd.testing.assert_frame_equal(table, alone)
    noisy = load_sweep(write_sweep(tmp_path, seeds=(0,), particles=(5,), duration=8.0))
    linked = noisy.grid | {"slam.fastslam.sigmaR+slam.fastslam.sigmaB": [[0.002, 0.01], [0.02, 0.1]]}
    noisy = dataclasses.replace(noisy, grid=linked)
    assert len({optimum_key(noisy, run) for run in noisy.runs()}) == 2


def test_resume_reuses_finished_runs_and_ignores_a_torn_line(tmp_path):
    sweep = load_sweep(write_sweep(tmp_path))
    first = run_sweep(sweep, tmp_path / "out", workers=1, progress=False)
    assert (first.ran, first.reused) == (4, 0)
    lines = (tmp_path / "out" / RESULTS).read_text().splitlines()
    (tmp_path / "out" / RESULTS).write_text("\n".join(lines[:2]) + "\n" + lines[2][:40])  # a crash mid-write
    second = run_sweep(sweep, tmp_path / "out", workers=1, progress=False)
    assert (second.ran, second.reused) == (2, 2)
    pd.testing.assert_frame_equal(first.table.drop(columns=TIMING), second.table.drop(columns=TIMING))


@pytest.mark.slow
def test_a_killed_sweep_resumes_with_nothing_lost(tmp_path):
    path = write_sweep(tmp_path, seeds=(0, 1, 2), particles=(5, 20, 40), duration=20.0)
    out = tmp_path / "out"
    command = [
        sys.executable,
        "-m",
        "mazeslam.cli",
        "sweep",
        str(path),
        "--out",
        str(out),
        "--workers",
        "1",
        "--quiet",
    ]
    process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.time() + 120
    while time.time() < deadline:
        results = out / RESULTS
        if results.exists() and len(results.read_text().splitlines()) >= 2:
            break
        time.sleep(0.1)
    process.send_signal(signal.SIGKILL)
    process.wait()
    before = [json.loads(line)["run_id"] for line in (out / RESULTS).read_text().splitlines() if line.endswith("}")]
    assert 2 <= len(before) < 9
    done = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert f"{9 - len(before)} run now" in done.stdout and f"{len(before)} already" in done.stdout
    table = pd.read_csv(out / "results.csv")
    assert len(table) == 9 and table.run_id.is_unique and set(before) <= set(table.run_id)


@pytest.mark.slow
def test_runs_on_a_dask_cluster_with_the_same_results(tmp_path):
    distributed = pytest.importorskip("distributed")
    sweep = load_sweep(write_sweep(tmp_path, seeds=(0,), particles=(5, 20)))
    local = run_sweep(sweep, tmp_path / "local", workers=1, progress=False).table.drop(columns=TIMING)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        remote = run_sweep(sweep, tmp_path / "dask", scheduler=cluster.scheduler_address, progress=False)
    pd.testing.assert_frame_equal(local, remote.table.drop(columns=TIMING))


def test_linked_settings_move_together(tmp_path):
    path = tmp_path / "linked.toml"
    path.write_text(
        "seeds = [0]\nduration = 10.0\n[grid]\n"
        '"slam.fastslam.sigmaR+slam.fastslam.sigmaB" = [[0.002, 0.01], [0.02, 0.1]]\n'
    )
    sweep = load_sweep(path)
    from mazeslam.sweeps.runner import configure

    _, slam = configure(sweep, sweep.runs()[1]["settings"])
    assert (slam.fastslam.sigmaR, slam.fastslam.sigmaB) == (0.02, 0.1)
    table = run_sweep(sweep, tmp_path / "out", workers=1, progress=False).table
    assert list(table["slam.fastslam.sigmaR+slam.fastslam.sigmaB"]) == ["0.002/0.01", "0.02/0.1"]
    path.write_text('seeds = [0]\n[grid]\n"slam.fastslam.sigmaR+slam.fastslam.sigmaB" = [[0.002]]\n')
    with pytest.raises(ConfigError, match="needs lists of 2 values"):
        load_sweep(path)


def test_a_sweep_over_a_grid_filter_setting_runs_the_grid_filter(tmp_path):
    """``slam.map.kind = "grid"`` in a sweep runs the grid filter (not corner FastSLAM) on the simulated
    course robot, and the particle count swept reaches it: its rows have the grid filter's errors and
    motion NIS, and no landmark map."""
    path = tmp_path / "grid.toml"
    path.write_text(
        'name = "grid"\nseeds = [0]\nduration = 20.0\n'
        f'simulation_config = "{PROJECT_ROOT / "configs" / "simulation_course_robot.toml"}"\n'
        f'slam_config = "{PROJECT_ROOT / "configs" / "course.toml"}"\n'
        '[grid]\n"slam.map.kind" = ["grid", "landmarks"]\n"slam.grid.particles" = [2, 6]\n'
    )
    table = run_sweep(load_sweep(path), tmp_path / "out", workers=1, progress=False).table
    grid = table[table["slam.map.kind"] == "grid"]
    landmarks = table[table["slam.map.kind"] == "landmarks"]
    assert len(grid) == 2 and len(landmarks) == 2
    assert (grid.landmarks == 0).all() and grid.map_rmse.isna().all() and grid.nis_mean.notna().all()
    assert (landmarks.landmarks > 0).all()
    # the particle count is the grid filter's: it changes the grid rows, not the corner FastSLAM ones
    assert grid.ate_rmse.nunique() == 2 and landmarks.ate_rmse.nunique() == 1
    summary = (tmp_path / "out" / "summary.md").read_text()  # reported like any FastSLAM sweep
    assert "slam.map.kind" in summary and "grid" in summary
