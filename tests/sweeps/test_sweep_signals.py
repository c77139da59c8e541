"""A sweep stopped from outside leaves nothing running: killed (``kill -9``), its workers end with it;
terminated (SIGTERM), it ends them, says so, exits with 143 and releases its folder, and the same
command then resumes it with nothing lost or run twice.

Processes are checked in ``/proc`` (Linux): a process is running while it exists and is not a
zombie (a dead orphan waits there for its new parent to collect it)."""

import json
import signal
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest
from conftest import PROJECT_ROOT
from processes import children, ended_within, kill_all, wait_until

from mazeslam.sweeps.runner import RESULTS, SweepLock

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="processes are read in /proc (Linux)")

#: Seconds the workers of a stopped sweep have to end.
GRACE = 3.0
#: 12 runs of about a second each on two workers: seconds of runs left once two have finished.
SWEEP = """name = "t"
seeds = [0, 1, 2, 3]
duration = 30.0
[grid]
"slam.fastslam.NPARTICLES" = [100, 200, 400]
"sim.laser.beams" = [90]
"""
RUNS = 12


def sweep_command(folder: Path) -> list[str]:
    (folder / "s.toml").write_text(SWEEP)
    out = str(folder / "out")
    return [sys.executable, "-m", "mazeslam.cli", "sweep", str(folder / "s.toml"), "--out", out, "--workers", "2"]


def start(command: list[str]) -> subprocess.Popen:
    return subprocess.Popen(
        [*command, "--quiet"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=PROJECT_ROOT
    )


@pytest.mark.slow  # about 3 s: the sweep starts (imports) before its workers
def test_a_killed_sweep_takes_its_workers_with_it(tmp_path):
    process = start(sweep_command(tmp_path))
    wait_until(process, lambda: len(children(process.pid)) == 2)
    workers = children(process.pid)
    try:
        process.kill()
        process.wait()
        assert ended_within(workers, GRACE)
    finally:
        kill_all(workers)


def finished(out: Path) -> list[str]:
    """The run ids in ``runs.jsonl`` (complete lines)."""
    results = out / RESULTS
    lines = results.read_text().splitlines() if results.exists() else []
    return [json.loads(line)["run_id"] for line in lines if line.endswith("}")]


@pytest.mark.slow
def test_a_terminated_sweep_stops_cleanly_and_resumes_with_nothing_lost_or_run_twice(tmp_path):
    command, out = sweep_command(tmp_path), tmp_path / "out"
    process = start(command)
    wait_until(process, lambda: len(finished(out)) >= 2)
    workers = children(process.pid)
    try:
        process.send_signal(signal.SIGTERM)
        _, err = process.communicate(timeout=GRACE)
        assert process.returncode == 128 + signal.SIGTERM, err
        assert ended_within(workers, GRACE)
    finally:
        process.kill()
        kill_all(workers)
    assert "t: interrupted (SIGTERM); the finished runs are kept in" in err and "Traceback" not in err
    assert not (out / SweepLock.NAME).exists()
    before = finished(out)
    assert 2 <= len(before) < RUNS
    done = subprocess.run([*command, "--quiet"], capture_output=True, text=True, timeout=300, cwd=PROJECT_ROOT)
    assert done.returncode == 0, done.stderr
    assert f"{RUNS - len(before)} run now" in done.stdout and f"{len(before)} already" in done.stdout
    table = pd.read_csv(out / "results.csv")
    assert len(table) == RUNS and table.run_id.is_unique and set(before) <= set(table.run_id)
    assert sorted(finished(out)) == sorted(table.run_id)  # each run once in runs.jsonl too
    assert not list((out / "maps").glob(".*.partial"))
