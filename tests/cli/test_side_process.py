"""The side process of ``mazeslam slam``: a call there gives what it gives here, its errors are
raised here, and a side process that died or never started leaves the work to this process."""

import os
import subprocess
import sys

import pytest
from conftest import PROJECT_ROOT

from mazeslam.cli.side_process import RemoteTraceback, SideProcess

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="the side process forks (Linux)")


def where_and_sum(values):
    return os.getpid(), sum(values)


def fails(message):
    raise KeyError(message)


def test_a_call_runs_in_the_other_process_and_gives_its_value():
    with SideProcess(["json"]) as side:
        assert side.running
        side.start(where_and_sum, [1, 2, 3])
        pid, total = side.result()
        side.start(where_and_sum, range(10))  # one call after another
        assert side.result()[1] == 45
    assert pid != os.getpid() and total == 6


def test_an_error_there_is_raised_here_with_its_traceback():
    with SideProcess() as side:
        side.start(fails, "no such landmark")
        with pytest.raises(KeyError, match="no such landmark") as raised:
            side.result()
    assert isinstance(raised.value.__cause__, RemoteTraceback)
    assert "in fails" in str(raised.value.__cause__)


def test_when_the_process_has_died_the_call_runs_here():
    with SideProcess() as side:
        side._process.kill()
        side._process.join()
        side.start(where_and_sum, [4, 5])
        assert side.result() == (os.getpid(), 9)


def test_inline_runs_the_call_here_when_its_result_is_asked_for():
    side = SideProcess.inline()
    assert not side.running
    side.start(where_and_sum, [1])
    assert side.result() == (os.getpid(), 1)
    with pytest.raises(RuntimeError, match="no call was started"):
        side.result()


def test_a_module_that_does_not_import_is_the_error_of_the_call_that_needs_it():
    with SideProcess(["mazeslam.no_such_module"]) as side:
        side.start(where_and_sum, [1])
        pid, total = side.result()
        side.start(__import__, "mazeslam.no_such_module")
        with pytest.raises(ModuleNotFoundError, match="no_such_module"):
            side.result()
    assert pid != os.getpid() and total == 1


def test_the_slam_command_leaves_matplotlib_to_its_side_process(tmp_path):
    """The figure and the map export are drawn in the side process: the command's own process never
    loads matplotlib, nor pandas, tabulate (the error table is formatted without them) or tqdm (no
    progress bar), and the outputs are all there."""
    from mazeslam import simulate

    log = simulate(tmp_path / "run.log", seed=1, duration=6.0, progress=False).log_path
    out = tmp_path / "out"
    code = (
        "import sys\n"
        "from mazeslam.cli.main import main\n"
        f"main(['slam', {str(log)!r}, '--particles', '20', '--out', {str(out)!r}, '--quiet'], standalone_mode=False)\n"
        "print(*(name in sys.modules for name in ('matplotlib', 'pandas', 'tabulate', 'tqdm')))\n"
    )
    printed = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=PROJECT_ROOT
    ).stdout
    assert printed.split()[-4:] == ["False"] * 4
    for name in ("slam.png", "occupancy.pgm", "occupancy.yaml", "occupancy.png", "landmarks.csv", "map.json"):
        assert (out / name).stat().st_size > 0, name
