"""A full disk (issue 36): every command that writes files, run in a subprocess whose files may not
grow past a few KiB (``ulimit -f``: ``RLIMIT_FSIZE`` set in ``preexec_fn``), says so in one line
naming the file it could not write, leaves no truncated file in place of a good one, and keeps the
results of the run before it.

Cases: 11 (slam with both maps at two limits, smooth, simulate at two limits and through the Python
API, both imports, a sweep); a subprocess each, so marked slow."""

from __future__ import annotations

import re
import resource
import subprocess
import sys
from pathlib import Path

import pytest
from cli_runs import cli
from fuzz_logs import carmen_log, mrclam_log

pytestmark = [pytest.mark.slow, pytest.mark.skipif(sys.platform == "win32", reason="resource limits are POSIX")]
KIB = 1024


def contents(folder: Path) -> dict[str, bytes]:
    """Every entry of ``folder``, hidden ones too (a staging folder left behind shows): name -> bytes."""
    return {path.name: b"<folder>" if path.is_dir() else path.read_bytes() for path in sorted(folder.iterdir())}


def run_with_small_files(args: list, limit: int) -> subprocess.CompletedProcess:
    """``mazeslam ARGS`` in a subprocess that cannot write files larger than ``limit`` bytes."""

    def small_files():
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, resource.RLIM_INFINITY))

    command = [Path(sys.executable).parent / "mazeslam", *map(str, args)]
    return subprocess.run(command, capture_output=True, text=True, preexec_fn=small_files, timeout=300)


@pytest.fixture(scope="module")
def data(tmp_path_factory) -> Path:
    """A simulated log (6 s), a CARMEN log and an MRCLAM dataset, each imported once before."""
    from mazeslam import simulate

    folder = tmp_path_factory.mktemp("full_disk")
    simulate(folder / "sim.log", seed=4, duration=6.0, progress=False)
    (folder / "carmen").mkdir()
    carmen_log(folder / "carmen" / "aces.log", seed=0)
    mrclam_log(folder / "mrclam" / "robot.log", seed=0)
    return folder


#: name: (the command's arguments, with {data} and {out} to fill in; the folder it writes; the file limit)
CASES = {
    "slam-landmarks-2KiB": (["slam", "{data}/sim.log", "--out", "{out}", "--quiet"], "{out}", 2 * KIB),
    "slam-landmarks-16KiB": (["slam", "{data}/sim.log", "--out", "{out}", "--quiet"], "{out}", 16 * KIB),
    "slam-grid-2KiB": (["slam", "{data}/sim.log", "--map", "grid", "--out", "{out}", "--quiet"], "{out}", 2 * KIB),
    "slam-grid-16KiB": (["slam", "{data}/sim.log", "--map", "grid", "--out", "{out}", "--quiet"], "{out}", 16 * KIB),
    "smooth-2KiB": (["smooth", "{data}/sim.log", "--out", "{out}"], "{out}", 2 * KIB),
    "simulate-1KiB": (["simulate", "--out", "{out}/run.log", "--duration", "10", "--quiet"], "{out}", KIB),
    "simulate-8KiB": (["simulate", "--out", "{out}/run.log", "--duration", "10", "--quiet"], "{out}", 8 * KIB),
    "sweep-16KiB": (["sweep", "configs/sweeps/smoke.toml", "--out", "{out}", "--quiet"], "{out}", 16 * KIB),
    "import-carmen-4KiB": (
        ["import", "carmen", "{data}/carmen/aces.carmen", "--out", "{out}/aces.log"],
        "{out}",
        4 * KIB,
    ),
    "import-mrclam-256B": (
        ["import", "mrclam", "{data}/mrclam/robot-dataset", "--robot", "1", "--out", "{out}/robot.log"],
        "{out}",
        256,
    ),
}


@pytest.mark.parametrize("case", list(CASES))
def test_a_full_disk_names_the_file_and_keeps_the_last_results(data, tmp_path, case):
    template, folder_template, limit = CASES[case]
    out = tmp_path / "out"
    args = [part.format(data=data, out=out) for part in template]
    status, output = cli(*args)  # the run before: no limit
    assert status == 0, output
    folder = Path(folder_template.format(out=out))
    before = contents(folder)
    assert max(len(data) for data in before.values()) > limit  # the limit stops the rerun
    done = run_with_small_files(args, limit)
    assert done.returncode == 1, done.stdout + done.stderr
    (line,) = done.stderr.splitlines()
    written = re.fullmatch(r"error: (.*): cannot write: (.*\W)?File too large", line)  # pyarrow adds its words
    assert written, line
    assert Path(written.group(1)).parent == folder and Path(written.group(1)).name in before
    assert contents(folder) == before


def test_the_python_simulate_on_a_full_disk_keeps_the_last_log(tmp_path):
    """``mazeslam.simulate`` itself, not only the command, stages its log and sidecars."""
    from mazeslam import simulate

    simulate(tmp_path / "run.log", seed=1, duration=10.0, progress=False)
    before = contents(tmp_path)
    code = (
        f"from mazeslam import simulate; simulate({str(tmp_path / 'run.log')!r}, seed=2, duration=10.0, progress=False)"
    )

    def small_files():
        resource.setrlimit(resource.RLIMIT_FSIZE, (8 * KIB, resource.RLIM_INFINITY))

    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, preexec_fn=small_files)
    assert done.returncode != 0 and "File too large" in done.stderr
    assert contents(tmp_path) == before
