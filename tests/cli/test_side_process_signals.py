"""Nothing left running: ``mazeslam slam`` killed (``kill -9``) or terminated (SIGTERM) while its side
process is alive takes the side process with it; the side process ends with its parent whichever
thread started it; ``stop_on_signals`` turns SIGTERM and SIGINT into ``Interrupted``, which unwinds
the process and exits with 128 + the signal's number.

Processes are checked in ``/proc`` (Linux, as the side process is): a process is running while it
exists and is not a zombie (a dead orphan waits there for its new parent to collect it)."""

import os
import signal
import subprocess
import sys
import textwrap
import time

import pytest
from conftest import PROJECT_ROOT
from processes import children, ended_within, kill_all, running

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="the side process forks (Linux)")

#: Seconds a killed parent's side process, or a terminated command, has to end (about 0.3 s on a
#: quiet machine; generous for a loaded one, where a signal waits for the numpy call in progress and
#: the side process, if it ignores SIGTERM while importing, is killed 2 s after it: 5 s was exceeded
#: once at load average 3.5 on 2 cores). A process left running (the fault this checks) never ends.
GRACE = 15.0
#: Particles enough for the filter to run for seconds: the command is signalled mid-run.
PARTICLES = "3000"


def slam_with_its_side_process(log_path, out) -> tuple[subprocess.Popen, int]:
    """``mazeslam slam`` started on ``log_path``, once its side process is running: (command, side pid)."""
    command = [sys.executable, "-m", "mazeslam.cli", "slam", str(log_path), "--particles", PARTICLES]
    process = subprocess.Popen(
        [*command, "--out", str(out), "--quiet"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        cwd=PROJECT_ROOT,
    )
    deadline = time.monotonic() + 60
    while not (found := children(process.pid)):
        if process.poll() is not None or time.monotonic() > deadline:
            process.kill()
            pytest.fail(f"no side process (exit {process.wait()}): {process.stderr.read().decode()[-2000:]}")
        time.sleep(0.01)
    (side,) = found
    return process, side


@pytest.mark.parametrize("signum", [signal.SIGKILL, signal.SIGTERM], ids=["SIGKILL", "SIGTERM"])
def test_the_side_process_ends_with_a_killed_or_terminated_slam(default_run, tmp_path, signum):
    process, side = slam_with_its_side_process(default_run.log_path, tmp_path / "out")
    try:
        process.send_signal(signum)
        began = time.monotonic()
        status = process.wait(timeout=GRACE)
        assert ended_within([side], GRACE - (time.monotonic() - began))
        # SIGTERM: killed by it, or, where the command turns it into Interrupted, exit status 143
        assert status in (-signum, 128 + signum)
        process.communicate(timeout=GRACE)  # the pipes it shared with its side process are closed
    finally:
        process.kill()
        kill_all([side])


def start_script(code: str) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-c", textwrap.dedent(code)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=PROJECT_ROOT,
    )


@pytest.mark.parametrize("thread", ["main", "other"])
def test_a_side_process_started_by_any_thread_ends_when_its_parent_is_killed(thread):
    """Started by the main thread it is told of its parent's death by the kernel; by another
    thread (whose end would send that signal too early), its polling thread notices."""
    script = start_script(
        f"""
        import os, threading, time
        from mazeslam.cli.side_process import SideProcess

        def start():
            side = SideProcess()
            side.start(os.getpid)
            print(side.result(), flush=True)
            time.sleep(60)

        if {thread == "main"!r}:
            start()
        threading.Thread(target=start, daemon=True).start()
        time.sleep(60)
        """
    )
    side = int(script.stdout.readline())
    try:
        assert running(side) and side != script.pid
        script.kill()
        script.wait()
        assert ended_within([side], GRACE)
    finally:
        script.kill()
        kill_all([side])


def test_a_side_process_ignores_ctrl_c_and_ends_when_terminated():
    """Ctrl-C reaches the whole process group: the side process leaves it to its parent."""
    from mazeslam.cli.side_process import SideProcess

    with SideProcess() as side:
        side.start(os.getpid)
        pid = side.result()
        os.kill(pid, signal.SIGINT)
        side.start(os.getpid)
        assert side.result() == pid  # still there, still serving
    assert not running(pid)


STOPPING = """
    import os, signal, sys, time
    from mazeslam.cli.side_process import Interrupted, stop_on_signals

    signum = signal.{name}
    before = signal.getsignal(signum)
    try:
        with stop_on_signals():
            os.kill(os.getpid(), signum)
            time.sleep(30)
    except Interrupted as stop:
        print("caught", stop.signal_name, stop.code, signal.getsignal(signum) is before, flush=True)
    with stop_on_signals():
        try:
            os.kill(os.getpid(), signum)
            time.sleep(30)
        finally:
            print("unwound", flush=True)
"""


@pytest.mark.parametrize("name, status", [("SIGTERM", 143), ("SIGINT", 130)])
def test_stop_on_signals_unwinds_and_exits_with_128_plus_the_signal(name, status):
    script = start_script(STOPPING.format(name=name))
    out, err = script.communicate(timeout=20)
    assert out.splitlines() == [f"caught {name} {status} True", "unwound"], err
    assert script.returncode == status
    assert "Traceback" not in err


@pytest.mark.parametrize("ending", ["normally", "with SystemExit(0)"])
def test_a_stop_swallowed_by_library_code_still_ends_in_interrupted(ending):
    """A signal's ``Interrupted`` raised inside code that catches everything (seen: numpy's lazy
    import of numpy.random) was lost, and the command went on and exited 0 (click ends with
    SystemExit(0))."""
    from mazeslam.cli.side_process import Interrupted, stop_on_signals

    before = signal.getsignal(signal.SIGTERM)
    with pytest.raises(Interrupted) as stopped, stop_on_signals():
        try:
            signal.raise_signal(signal.SIGTERM)
        except BaseException:  # the library that swallows it
            pass
        if ending != "normally":
            raise SystemExit(0)
    assert stopped.value.code == 128 + signal.SIGTERM
    assert signal.getsignal(signal.SIGTERM) == before  # the handler given back


def test_after_a_swallowed_stop_no_output_replaces_a_file(tmp_path):
    """The run that went on after its stop was swallowed must not then replace the last results."""
    from mazeslam.cli.side_process import Interrupted, stop_on_signals
    from mazeslam.core.outputs import staged_outputs, write_file

    (tmp_path / "result.txt").write_text("the last run's\n")
    with pytest.raises(Interrupted), stop_on_signals():
        try:
            signal.raise_signal(signal.SIGTERM)
        except BaseException:  # swallowed
            pass
        with staged_outputs(tmp_path, ("*.txt",)) as staging:
            write_file(staging / "result.txt", "this run's\n")
    assert (tmp_path / "result.txt").read_text() == "the last run's\n"
    assert sorted(path.name for path in tmp_path.iterdir()) == ["result.txt"]  # no staging folder left
    write_file(tmp_path / "result.txt", "after the command\n")  # outside the block, writes work again
    assert (tmp_path / "result.txt").read_text() == "after the command\n"
