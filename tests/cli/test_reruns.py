"""Reruns lose nothing (issue 36): ``slam`` and ``smooth`` replace the last run's files only once a
run has written all of its own. A run that fails (a config error, a full disk) or is interrupted
leaves the folder as it was, with one line naming the file; a run that succeeds replaces every file;
a log does not take over the default folder of another log of the same name."""

from __future__ import annotations

import errno
import multiprocessing
import re
import resource
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from cli_runs import cli

from mazeslam.core.outputs import STAGING_PREFIX


def contents(folder: Path) -> dict[str, bytes]:
    """Every entry of ``folder``, hidden ones too (a staging folder left behind shows): name -> bytes."""
    return {path.name: b"<folder>" if path.is_dir() else path.read_bytes() for path in sorted(folder.iterdir())}


@pytest.fixture(scope="module")
def short_log(tmp_path_factory) -> Path:
    """A 6-second simulated run with its sidecars."""
    from mazeslam import simulate

    out = tmp_path_factory.mktemp("data") / "short.log"
    simulate(out, seed=1, duration=6.0, progress=False)
    return out


@pytest.fixture
def last_run(short_log, tmp_path) -> Path:
    """The folder of a good ``slam`` run of ``short_log``, and a file of the user's in it."""
    out = tmp_path / "out"
    status, output = cli("slam", short_log, "--out", out, "--quiet")
    assert status == 0, output
    (out / "notes.txt").write_text("the user's own file\n")
    return out


def test_a_rerun_with_a_config_error_keeps_the_last_results(short_log, last_run, tmp_path):
    before = contents(last_run)
    config = tmp_path / "simulation.toml"
    config.write_text("[maze]\nrows = 4\n")  # a simulator config given to slam
    status, output = cli("slam", short_log, "--out", last_run, "--config", config, "--quiet")
    assert status == 2
    assert len(output.splitlines()) == 1 and output.startswith(f"error: {config}: unknown parameter(s) maze"), output
    assert contents(last_run) == before


@pytest.mark.parametrize("failure", [KeyboardInterrupt(), OSError(errno.EFBIG, "File too large")])
def test_a_run_that_stops_while_writing_leaves_the_folder_as_it_was(short_log, last_run, monkeypatch, failure):
    """best_trajectory.csv stops half-written (after trajectory.csv and trajectory.tum were written)."""
    before = contents(last_run)
    savetxt = np.savetxt

    def stops_partway(path, table, *args, **kwargs):
        if not Path(path).name.startswith(".best_trajectory"):
            return savetxt(path, table, *args, **kwargs)
        savetxt(path, table[: len(table) // 2], *args, **kwargs)
        raise failure

    monkeypatch.setattr(np, "savetxt", stops_partway)
    status, output = cli("slam", short_log, "--out", last_run, "--quiet")
    assert status == 1
    expected = "Aborted!" if isinstance(failure, KeyboardInterrupt) else "error: {}: cannot write: File too large"
    assert output.splitlines()[-1] == expected.format(last_run / "best_trajectory.csv")
    assert contents(last_run) == before


def test_a_run_that_fails_while_the_side_process_draws_leaves_the_folder_as_it_was(short_log, last_run, monkeypatch):
    """The side process draws slam.png into the staging folder while this one scores: an error in
    the scoring ends the side process before the staging folder goes."""
    from mazeslam.cli import slam

    def fails(*args, **kwargs):
        raise ValueError("the scoring failed")

    monkeypatch.setattr(slam, "score_run", fails)
    before = contents(last_run)
    with pytest.raises(ValueError, match="the scoring failed"):
        slam.run_slam_command(short_log, None, last_run, progress=False, side_process=True)
    assert not multiprocessing.active_children()
    assert contents(last_run) == before


def test_a_full_disk_names_the_file_and_keeps_the_last_results(short_log, last_run):
    """Files over 16 KiB cannot be written (``ulimit -f 16``): slam.png (about 60 KiB), drawn by the side process."""
    before = contents(last_run)

    def small_files():
        resource.setrlimit(resource.RLIMIT_FSIZE, (16 * 1024, resource.RLIM_INFINITY))

    command = [Path(sys.executable).parent / "mazeslam", "slam", short_log, "--out", last_run, "--quiet"]
    done = subprocess.run(command, capture_output=True, text=True, preexec_fn=small_files, timeout=120)
    assert done.returncode == 1, done.stderr
    assert done.stderr.splitlines() == [f"error: {last_run / 'slam.png'}: cannot write: File too large"]
    assert contents(last_run) == before


def test_a_successful_rerun_replaces_every_file(short_log, tmp_path):
    """A landmarks run with an animation, then a grid run: no slam.gif or landmarks.csv of the first
    beside the second's files, and every file of the command's is new (none kept from the first)."""
    out = tmp_path / "out"
    assert cli("slam", short_log, "--out", out, "--animate", "--quiet")[0] == 0
    (out / "notes.txt").write_text("the user's own file\n")
    first = {path.name: path.stat().st_ino for path in out.iterdir()}
    assert {"slam.gif", "landmarks.csv", "slam.png"} <= set(first)
    status, output = cli("slam", short_log, "--out", out, "--map", "grid", "--quiet")
    assert status == 0, output
    wrote = {Path(path).name for path in re.search(r"^wrote (.*)$", output, re.M).group(1).split(", ")}
    second = {path.name: path.stat().st_ino for path in out.iterdir()}
    assert set(second) == wrote | {"occupancy.pgm", "notes.txt"}  # the map beside its .yaml
    assert not {"slam.gif", "landmarks.csv"} & set(second)
    assert [name for name in second if second[name] == first.get(name)] == ["notes.txt"]


def test_two_logs_of_one_name_do_not_share_the_default_folder(tmp_path, monkeypatch):
    from mazeslam import simulate

    monkeypatch.chdir(tmp_path)
    for folder, seed in [("a", 1), ("b", 2)]:
        simulate(Path(folder) / "run.log", seed=seed, duration=4.0, progress=False)
    assert cli("slam", "a/run.log", "--quiet")[0] == 0
    default = Path("runs/run/slam")
    before = contents(default)
    status, output = cli("slam", "b/run.log", "--quiet")
    assert status == 1
    assert output.splitlines() == [
        f"error: {default} holds the slam run of another log named run.log (a/run.log); "
        f"give --out for b/run.log, or remove {default}"
    ]
    assert contents(default) == before
    assert cli("slam", "b/run.log", "--out", "runs/run-b/slam", "--quiet")[0] == 0
    assert cli("slam", tmp_path / "a" / "run.log", "--quiet")[0] == 0  # the same log, however named
    assert cli("smooth", "a/run.log")[0] == 0
    status, output = cli("smooth", "b/run.log")
    assert status == 1 and "runs/run/smooth holds the smooth run of another log named run.log" in output


def test_smooth_keeps_the_last_results_when_a_rerun_fails(short_log, tmp_path):
    out = tmp_path / "smooth"
    assert cli("smooth", short_log, "--out", out)[0] == 0
    assert {"trajectory.csv", "map.json", "smooth.png"} <= {path.name for path in out.iterdir()}
    before = contents(out)
    config = tmp_path / "bad.toml"
    config.write_text("[fastslam]\nNPARTICLES = -1\n")
    status, output = cli("smooth", short_log, "--out", out, "--config", config)
    assert status == 2 and output.startswith("error: ") and len(output.splitlines()) == 1, output
    assert contents(out) == before
    assert not [path for path in out.iterdir() if path.name.startswith(STAGING_PREFIX)]
