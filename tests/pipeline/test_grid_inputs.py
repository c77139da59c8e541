"""Logs the grid filter cannot map are refused in one line naming the log and the setting: no scans,
no usable return, an odometry glitch that would make the map larger than memory."""

import subprocess
import sys

import pytest

from mazeslam.data.loaded_run import load_run
from mazeslam.pipeline import MapKind, SlamConfig, run_slam

GRID = SlamConfig(map=SlamConfig().map.__class__(kind=MapKind.GRID))
BEAMS = 36


# 5000.3 m along 0.7 rad (cos 0.765, sin 0.644) plus the laser's 20 m either side: 3864 x 3261 m.


def write_log(path, steps: list[float], ranges: float = 1.0, odometry_only: bool = False):
    """A drive 0.7 rad off the x axis: an odometry record of each step (m; the first also turns) and,
    unless ``odometry_only``, a scan of ``BEAMS`` beams of ``ranges`` m after it."""
    lines, t = [], 0.0
    for index, step in enumerate(steps):
        t += 0.2
        lines.append(f"{t:.1f} 0 {step} {0.7 if index == 0 else 0.0} " + " ".join(["-1"] * (BEAMS - 2)))
        if not odometry_only:
            t += 0.2
            lines.append(f"{t:.1f} 1 " + " ".join([f"{ranges:g}"] * BEAMS))
    path.write_text("\n".join(lines) + "\n")
    return path


def test_a_five_kilometre_glitch_is_refused_before_the_map_grows(tmp_path):
    path = write_log(tmp_path / "jump.log", [0.1, 0.1, 5000.0, 0.1])
    with pytest.raises(
        ValueError,
        match=r"jump.log: the odometry spans 3864 m x 3261 m \(its longest step, line 5, 5e\+03 m\).*jump_tolerance",
    ):
        run_slam(load_run(path), GRID, progress=False)


def test_a_log_without_scans_or_returns_is_refused_in_words(tmp_path):
    with pytest.raises(ValueError, match='no scan records.*kind = "landmarks"'):
        run_slam(load_run(write_log(tmp_path / "odometry.log", [0.1] * 5, odometry_only=True)), GRID, progress=False)
    with pytest.raises(ValueError, match=r"no scan has a return between \[grid.grid\] min_range"):
        run_slam(load_run(write_log(tmp_path / "blind.log", [0.1] * 5, ranges=0.0)), GRID, progress=False)


def test_the_command_says_it_in_one_line_and_writes_nothing(tmp_path):
    path = write_log(tmp_path / "jump.log", [0.1, 0.1, 5000.0, 0.1])
    out = tmp_path / "out"
    command = [sys.executable, "-m", "mazeslam.cli", "slam", str(path), "--map", "grid", "--quiet", "--out", str(out)]
    done = subprocess.run(command, capture_output=True, text=True)
    assert done.returncode == 2 and done.stderr.startswith("error: ") and len(done.stderr.splitlines()) == 1
    assert "jump_tolerance" in done.stderr and not (out / "occupancy.pgm").exists()


def test_info_shows_the_longest_odometry_step_and_its_line(tmp_path):
    path = write_log(tmp_path / "jump.log", [0.1, 0.1, 5000.0, 0.1])
    done = subprocess.run([sys.executable, "-m", "mazeslam.cli", "info", str(path)], capture_output=True, text=True)
    assert "longest step      5000.000 m (line 5)" in done.stdout
