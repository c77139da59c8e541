"""Processes the tests start, read in ``/proc`` (Linux): whether one is running, its children, and
waiting for them to end. A process is running while it exists and is not a zombie (a dead orphan
waits there for its new parent to collect it)."""

import os
import signal
import subprocess
import time
from pathlib import Path

import pytest


def running(pid: int) -> bool:
    """Whether process ``pid`` exists and is not a zombie."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat.rsplit(")", 1)[1].split()[0] != "Z"


def children(pid: int) -> list[int]:
    """The running processes whose parent is ``pid``."""
    found = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
            except OSError:  # ended meanwhile
                continue
            if int(fields[1]) == pid and fields[0] != "Z":
                found.append(int(entry.name))
    return found


def ended_within(pids, seconds: float) -> bool:
    """Whether every one of ``pids`` has ended within ``seconds``."""
    deadline = time.monotonic() + seconds
    while any(running(pid) for pid in pids):
        if time.monotonic() > deadline:
            return False
        time.sleep(0.02)
    return True


def kill_all(pids) -> None:
    """Clean-up after a failed test: no process of it left behind."""
    for pid in pids:
        if running(pid):
            os.kill(pid, signal.SIGKILL)


def wait_until(process: subprocess.Popen, condition, seconds: float = 120) -> None:
    """Wait for ``condition()`` while ``process`` runs; fail the test (the process killed, its last
    error output shown) if it ends first or ``seconds`` pass."""
    deadline = time.monotonic() + seconds
    while not condition():
        if process.poll() is not None or time.monotonic() > deadline:
            process.kill()
            pytest.fail(f"ended early or hung (exit {process.wait()}): {process.stderr.read()[-2000:]}")
        time.sleep(0.01)
