"""Files written whole or not at all, and a run's set of files replacing the last run's only once
complete (issue 36): ``mazeslam.core.outputs.written``, ``write_file`` and ``staged_outputs``."""

from __future__ import annotations

import errno
import os
import pickle
import signal
import threading
import time
from pathlib import Path

import pytest

from mazeslam.core import outputs
from mazeslam.core.outputs import STAGING_PREFIX, WriteError, staged_outputs, write_file, written

PATTERNS = ("trajectory.csv", "map.json", "*.tum", "slam.png", "slam.gif")


def contents(folder: Path) -> dict[str, bytes]:
    """Every entry of ``folder`` (hidden ones too): file name -> bytes; a folder's name -> b"<folder>"."""
    return {path.name: b"<folder>" if path.is_dir() else path.read_bytes() for path in sorted(folder.iterdir())}


@pytest.fixture
def last_run(tmp_path) -> Path:
    """An output folder holding a complete earlier run and a file of the user's."""
    folder = tmp_path / "out"
    folder.mkdir()
    for name in ["trajectory.csv", "map.json", "truth.tum", "slam.gif"]:
        (folder / name).write_text(f"the last run's {name}\n")
    (folder / "notes.txt").write_text("the user's own file\n")
    return folder


def test_written_replaces_the_file_only_when_complete(tmp_path):
    path = tmp_path / "map.json"
    path.write_text("old\n")
    with written(path) as temporary:
        assert temporary.parent == tmp_path and temporary.suffix == ".json"  # the suffix picks a format
        temporary.write_text("new\n")
        assert path.read_text() == "old\n"
    assert path.read_text() == "new\n"
    assert [p.name for p in tmp_path.iterdir()] == ["map.json"]


@pytest.mark.parametrize("failure", [OSError(errno.EFBIG, "File too large"), KeyboardInterrupt()])
def test_a_write_that_fails_leaves_the_old_file_and_no_temporary(tmp_path, failure):
    path = tmp_path / "trajectory.csv"
    path.write_text("old\n")
    with pytest.raises(WriteError if isinstance(failure, OSError) else KeyboardInterrupt) as raised:
        with written(path) as temporary:
            temporary.write_text("half a fi")
            raise failure
    assert path.read_text() == "old\n"
    assert [p.name for p in tmp_path.iterdir()] == ["trajectory.csv"]
    if isinstance(failure, OSError):
        assert str(raised.value) == f"{path}: cannot write: File too large"


def test_write_file_names_the_file_it_cannot_write(tmp_path):
    with pytest.raises(WriteError, match=rf"^{tmp_path}/gone/map.json: cannot write: No such file or directory$"):
        write_file(tmp_path / "gone" / "map.json", "{}\n")
    assert write_file(tmp_path / "map.pgm", b"P5\n").read_bytes() == b"P5\n"


def test_a_write_error_pickles_whole():
    """A side process raises it in the main one: path and reason survive the pipe."""
    error = pickle.loads(pickle.dumps(WriteError(Path("out/slam.png"), "File too large")))
    assert (error.path, error.reason, str(error)) == (
        Path("out/slam.png"),
        "File too large",
        "out/slam.png: cannot write: File too large",
    )


def test_a_run_replaces_the_last_runs_files_once_complete(last_run):
    with staged_outputs(last_run, PATTERNS) as staging:
        assert staging.parent == last_run and staging.name.startswith(STAGING_PREFIX)
        (staging / "trajectory.csv").write_text("new trajectory\n")
        (staging / "map.json").write_text("new map\n")
        (staging / "slam.png").write_text("new figure\n")
        assert (last_run / "slam.gif").exists()  # nothing replaced before the run ends
    assert contents(last_run) == {
        "map.json": b"new map\n",
        "notes.txt": b"the user's own file\n",  # not the command's: left alone
        "slam.png": b"new figure\n",
        "trajectory.csv": b"new trajectory\n",
    }  # truth.tum and slam.gif were the last run's, not this one's: gone


@pytest.mark.parametrize("failure", [ValueError("a config error"), KeyboardInterrupt(), SystemExit(143)])
def test_a_failed_or_interrupted_run_leaves_the_folder_as_it_was(last_run, failure):
    before = contents(last_run)
    with pytest.raises(type(failure)):
        with staged_outputs(last_run, PATTERNS) as staging:
            (staging / "trajectory.csv").write_text("new trajectory\n")
            (staging / "map.json").write_text("half a ma")
            raise failure
    assert contents(last_run) == before  # byte for byte, and no staging folder left


def test_a_write_error_names_the_file_of_the_output_folder(last_run):
    before = contents(last_run)
    with pytest.raises(WriteError) as raised:
        with staged_outputs(last_run, PATTERNS) as staging:
            with written(staging / "slam.png"):
                raise OSError(errno.EFBIG, "File too large")
    assert str(raised.value) == f"{last_run}/slam.png: cannot write: File too large"
    assert contents(last_run) == before


def test_two_runs_into_one_folder_never_mix_the_last_to_finish_wins(last_run):
    """Both run at once; each replaces the whole set when it ends, so the folder holds one run's files."""
    with staged_outputs(last_run, PATTERNS) as first, staged_outputs(last_run, PATTERNS) as second:
        (first / "map.json").write_text("first\n")
        (first / "slam.gif").write_text("first\n")
        (second / "map.json").write_text("second\n")
        (second / "slam.png").write_text("second\n")
    # `second` ended first (inner block), then `first`: the folder holds first's files only
    assert contents(last_run) == {"map.json": b"first\n", "notes.txt": b"the user's own file\n", "slam.gif": b"first\n"}


@pytest.mark.skipif(outputs.fcntl is None, reason="no flock here")
def test_a_run_waits_for_another_runs_replacing(last_run):
    """The replacing holds a lock on the folder: while another holds it, nothing is replaced."""
    other = os.open(last_run, os.O_RDONLY)
    outputs.fcntl.flock(other, outputs.fcntl.LOCK_EX)
    done = threading.Event()

    def run():
        with staged_outputs(last_run, PATTERNS) as staging:
            (staging / "map.json").write_text("new\n")
        done.set()

    thread = threading.Thread(target=run)
    try:
        thread.start()
        time.sleep(0.3)
        assert not done.is_set() and (last_run / "map.json").read_text() == "the last run's map.json\n"
    finally:
        os.close(other)  # the lock goes with it
    thread.join(timeout=10)
    assert done.is_set() and contents(last_run) == {"map.json": b"new\n", "notes.txt": b"the user's own file\n"}


@pytest.mark.skipif(outputs.fcntl is None, reason="no flock here")
def test_a_killed_runs_staging_folder_goes_with_the_next_run_a_running_ones_stays(last_run):
    abandoned = last_run / f"{STAGING_PREFIX}999999-dead"
    abandoned.mkdir()
    (abandoned / "map.json").write_text("half a ma")
    with staged_outputs(last_run, PATTERNS) as running, staged_outputs(last_run, PATTERNS) as staging:
        assert not abandoned.exists()
        assert running.is_dir()  # locked by its run: not taken for abandoned
        (staging / "map.json").write_text("new\n")
    assert not [p for p in last_run.iterdir() if p.name.startswith(STAGING_PREFIX)]


def test_ctrl_c_while_files_are_moved_in_waits_until_all_are(last_run, monkeypatch):
    """Ctrl-C in the middle of the replacing is held until the new set is complete, then raised."""
    replace = os.replace
    moved = []

    def interrupted_replace(source, target):
        if not moved:
            signal.raise_signal(signal.SIGINT)  # the handler runs now: between two renames
        replace(source, target)
        moved.append(Path(target).name)

    monkeypatch.setattr(outputs.os, "replace", interrupted_replace)
    # Ctrl-C's own handler, whatever the test process had (a test runner's worker may differ).
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        check_that_ctrl_c_waits(last_run, moved)
    finally:
        signal.signal(signal.SIGINT, previous)


def check_that_ctrl_c_waits(last_run, moved):
    with pytest.raises(KeyboardInterrupt):
        with staged_outputs(last_run, PATTERNS) as staging:
            for name in ["trajectory.csv", "map.json", "slam.png"]:
                (staging / name).write_text(f"new {name}\n")
    assert sorted(moved) == ["map.json", "slam.png", "trajectory.csv"]
    assert contents(last_run) == {
        "map.json": b"new map.json\n",
        "notes.txt": b"the user's own file\n",
        "slam.png": b"new slam.png\n",
        "trajectory.csv": b"new trajectory.csv\n",
    }
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
