"""Where a command writes its results by default, and how a rerun replaces the last run's files.

Results go to ``runs/<log name>/<command>/`` under the current directory, never beside the input
log (a data folder may be read-only or shared). A run writes its files into a staging folder and,
once every one is written, replaces the files the command writes (``SLAM_FILES``, ``SMOOTH_FILES``)
with them (``mazeslam.core.outputs.staged_outputs``): a ``slam.gif`` of an earlier run never sits
beside a new ``slam.png``, and a run that fails or is interrupted leaves the last run's files as
they were. Files the command does not know are left alone. Two logs of one name in different
folders (``a/run.log``, ``b/run.log``) have the same default folder: a run does not replace the
default folder's run of another log (``check_same_log``); ``--out`` says where it goes instead.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from mazeslam.core.outputs import OutputError, prepare_output_folder
from mazeslam.core.outputs import clear_outputs as clear_outputs  # importable from here, where it was

#: The files ``mazeslam slam`` writes (glob patterns, in its output folder).
SLAM_FILES = (
    "trajectory.csv",
    "best_trajectory.csv",
    "map.json",
    "*.tum",
    "slam.png",
    "slam.gif",
    "slam.mp4",
    "occupancy.pgm",
    "occupancy.yaml",
    "occupancy.png",
    "landmarks.csv",
)
#: The files ``mazeslam smooth`` writes.
SMOOTH_FILES = ("trajectory.csv", "map.json", "*.tum", "smooth.png", "occupancy.pgm", "occupancy.yaml")


def default_out_dir(log_file: str | Path, command: str, base: str | Path = "runs") -> Path:
    """``base``/<log name>/``command``: e.g. ``runs/log1/slam`` for ``../data/log1.txt``, relative
    to the current directory."""
    return Path(base) / Path(log_file).stem / command


def check_same_log(folder: str | Path, log_file: str | Path, command: str) -> None:
    """Refuse to replace the run of another log: ``OutputError`` when ``folder``'s ``map.json``
    records a ``source`` log other than ``log_file`` (the same file however named is the same log).
    A folder without a readable ``map.json`` or without a ``source`` in it holds no run to keep."""
    folder = Path(folder)
    try:
        source = json.loads((folder / "map.json").read_text(encoding="utf-8")).get("source")
    except (OSError, ValueError, AttributeError):  # none, unreadable, not JSON, not an object
        return
    if not isinstance(source, str) or Path(source).resolve() == Path(log_file).resolve():
        return
    raise OutputError(
        f"{folder} holds the {command} run of another log named {Path(log_file).name} ({source}); "
        f"give --out for {log_file}, or remove {folder}"
    )


@contextmanager
def output_folder(path: str | Path) -> Iterator[Path]:
    """The folder ``path``, created and probed (``prepare_output_folder``) for the block; when the
    block fails, the folders it created and left empty are removed again (a first run that fails
    leaves no empty ``runs/<log name>/slam/`` behind)."""
    path = Path(path)
    created = [folder for folder in (path, *path.parents) if not folder.exists()]  # deepest first
    prepare_output_folder(path)
    try:
        yield path
    except BaseException:
        for folder in created:
            if not folder.is_dir() or any(folder.iterdir()):
                break
            folder.rmdir()
        raise
