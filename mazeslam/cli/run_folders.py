"""Where a command writes its results by default, and how a rerun replaces the last run's files.

Results go to ``runs/<log name>/<command>/`` under the current directory, never beside the input
log (a data folder may be read-only or shared). A rerun into a folder first removes the files the
command writes (so that a ``slam.gif`` of an earlier run never sits beside a new ``slam.png``);
files it does not know are left alone.
"""

from __future__ import annotations

from pathlib import Path

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
SMOOTH_FILES = ("trajectory.csv", "map.json", "*.tum", "smooth.png")


def default_out_dir(log_file: str | Path, command: str, base: str | Path = "runs") -> Path:
    """``base``/<log name>/``command``: e.g. ``runs/log1/slam`` for ``../data/log1.txt``, relative
    to the current directory."""
    return Path(base) / Path(log_file).stem / command


def clear_outputs(folder: str | Path, patterns: tuple[str, ...]) -> list[Path]:
    """Remove the files of ``folder`` matching ``patterns`` (not folders, not other files);
    returns those removed."""
    removed = []
    for pattern in patterns:
        for path in sorted(Path(folder).glob(pattern)):
            if path.is_file() or path.is_symlink():
                path.unlink()
                removed.append(path)
    return removed
