"""Interrupts (issue 36): ``mazeslam slam`` and ``mazeslam sweep`` stopped from outside with SIGINT
(Ctrl-C), SIGTERM or SIGKILL (``kill -9``) while they run leave nothing running, leave their output
folder consistent (the last run's files intact, or the new run complete) and rerun cleanly.

Cases: 2 commands x 3 signals = 6. Each starts the command in a subprocess and waits for it to be
working (slam: its side process forked; sweep: a run finished); seconds each, so marked slow.
Processes are read in /proc (Linux)."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import PROJECT_ROOT
from processes import children, ended_within, kill_all, wait_until

from mazeslam.core.outputs import STAGING_PREFIX
from mazeslam.data import sidecars
from mazeslam.sweeps.runner import RESULTS, SweepLock

pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(not sys.platform.startswith("linux"), reason="processes are read in /proc (Linux)"),
]
SIGNALS = [signal.SIGINT, signal.SIGTERM, signal.SIGKILL]
#: Seconds a stopped command and its children have to end (a signal waits for the numpy call in progress).
GRACE = 10.0


def mazeslam(*args) -> list[str]:
    return [sys.executable, "-m", "mazeslam.cli", *map(str, args), "--quiet"]


def start(command: list[str]) -> subprocess.Popen:
    return subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=PROJECT_ROOT)


def stop(process: subprocess.Popen, signum: int) -> tuple[int, str]:
    """Send ``signum``; (exit status, stderr) once the process and every child it had have ended."""
    family = children(process.pid)
    try:
        process.send_signal(signum)
        _, err = process.communicate(timeout=GRACE)
        assert ended_within(family, GRACE), f"left running: {[pid for pid in family if pid in children(1)]}"
    finally:
        process.kill()
        kill_all(family)
    return process.returncode, err


def visible(folder: Path) -> dict[str, bytes]:
    """The folder's files but staging folders: name -> bytes."""
    return {path.name: path.read_bytes() for path in sorted(folder.iterdir()) if not path.name.startswith(".")}


def stopped_as(status: int, err: str, signum: int) -> None:
    """A clean stop exits with 128 + the signal's number and says so; SIGKILL cannot be caught."""
    if signum == signal.SIGKILL:
        assert status == -signal.SIGKILL
    else:
        assert status == 128 + signum, err
        assert "Traceback" not in err and f"interrupted ({signal.Signals(signum).name})" in err, err


# -- slam ----------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def short_log(tmp_path_factory) -> Path:
    from mazeslam import simulate

    out = tmp_path_factory.mktemp("interrupts") / "short.log"
    simulate(out, seed=2, duration=6.0, progress=False)
    return out


def assert_complete_slam_folder(folder: Path, records: int) -> None:
    names = {path.name for path in folder.iterdir()}
    assert {"trajectory.csv", "best_trajectory.csv", "map.json", "slam.png", "landmarks.csv"} <= names
    times, poses, covariances = sidecars.read_trajectory(folder / "trajectory.csv")
    assert len(times) == records and np.isfinite(poses).all() and np.isfinite(covariances).all()
    json.loads((folder / "map.json").read_text())
    assert not [name for name in names if name.startswith(STAGING_PREFIX)]


@pytest.mark.parametrize("signum", SIGNALS, ids=lambda s: signal.Signals(s).name)
def test_an_interrupted_slam_leaves_nothing_running_and_its_folder_consistent(short_log, tmp_path, signum):
    out = tmp_path / "out"
    records = len(sidecars.read_truth(sidecars.truth_path(short_log))[0])
    assert subprocess.run(mazeslam("slam", short_log, "--out", out), cwd=PROJECT_ROOT, timeout=120).returncode == 0
    before = visible(out)
    process = start(mazeslam("slam", short_log, "--out", out, "--particles", 3000, "--seed", 1))
    wait_until(process, lambda: len(children(process.pid)) > 0)  # its side process: the filter runs
    status, err = stop(process, signum)
    if status == 0:  # finished before the signal came: the new run is complete
        assert_complete_slam_folder(out, records)
    else:
        stopped_as(status, err, signum)
        assert visible(out) == before
    rerun = subprocess.run(
        mazeslam("slam", short_log, "--out", out), cwd=PROJECT_ROOT, timeout=120, text=True, capture_output=True
    )
    assert rerun.returncode == 0, rerun.stderr
    assert_complete_slam_folder(out, records)  # a staging folder left by kill -9 is gone too
    rerun_files, before_files = visible(out), dict(before)
    assert rerun_files.pop("map.json") != b"" and before_files.pop("map.json") != b""  # holds timings
    assert rerun_files == before_files  # the same command, the same bytes


# -- sweep ---------------------------------------------------------------------------------------------

SWEEP = """name = "t"
seeds = [0, 1, 2]
duration = 20.0
[grid]
"slam.fastslam.NPARTICLES" = [100, 300]
"""
RUNS = 6


def finished(out: Path) -> list[str]:
    """The run ids in ``runs.jsonl`` (complete lines)."""
    results = out / RESULTS
    lines = results.read_text().splitlines() if results.exists() else []
    return [json.loads(line)["run_id"] for line in lines if line.endswith("}")]


@pytest.mark.parametrize("signum", SIGNALS, ids=lambda s: signal.Signals(s).name)
def test_an_interrupted_sweep_leaves_nothing_running_and_resumes_cleanly(tmp_path, signum):
    (tmp_path / "s.toml").write_text(SWEEP)
    out = tmp_path / "out"
    command = mazeslam("sweep", tmp_path / "s.toml", "--out", out, "--workers", 2)
    process = start(command)
    wait_until(process, lambda: len(finished(out)) >= 1)
    status, err = stop(process, signum)
    done_before = finished(out)
    if status != 0:
        stopped_as(status, err, signum)
        if signum != signal.SIGKILL:
            assert not (out / SweepLock.NAME).exists()  # released; after kill -9 the next sweep takes it over
    assert len(done_before) == len(set(done_before)) <= RUNS
    rerun = subprocess.run(command, capture_output=True, text=True, timeout=300, cwd=PROJECT_ROOT)
    assert rerun.returncode == 0, rerun.stderr
    table = pd.read_csv(out / "results.csv")
    assert len(table) == RUNS and table.run_id.is_unique and set(done_before) <= set(table.run_id)
    assert sorted(finished(out)) == sorted(table.run_id)  # each run once: none lost, none run twice
    assert np.isfinite(table[["ate_rmse", "ate_aligned_rmse"]].to_numpy()).all()
    assert not (out / SweepLock.NAME).exists()
