"""The side process's sender thread (``SideProcess.start`` writes a pickled call to the pipe from a
thread): a call far larger than the pipe's buffer gives the same value there as here, runs here when
the other process has been killed (before the call, or while the write is blocked on it), and
leaving the ``with`` block without asking for the result does not hang on a blocked write.

A write is made to block by a side process still busy importing its modules: one that sleeps on
import (``slow_module``), as matplotlib's import holds the real one. Every call that could hang runs
under ``within``, which fails the test after ``GUARD`` seconds instead of hanging it (and then kills
the side process, which ends the write); nothing here asserts how fast anything is.
"""

import contextlib
import hashlib
import itertools
import os
import signal
import sys
import threading
from collections.abc import Callable

import numpy as np
import pytest

from mazeslam.cli.side_process import SideProcess

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="the side process forks (Linux)")

#: Seconds before a call that should return at once is taken to hang (only reached when it does).
GUARD = 20.0
#: 2 MiB of seeded bytes: well beyond a socket pair's buffers (about 200 kB each way on Linux).
PAYLOAD = np.random.default_rng(0).bytes(2 * 1024 * 1024)
_names = itertools.count()


def digest(payload: bytes) -> tuple[int, int, str]:
    """Where it ran, and the length and SHA-256 of what it was given."""
    return os.getpid(), len(payload), hashlib.sha256(payload).hexdigest()


EXPECTED = digest(PAYLOAD)[1:]


@pytest.fixture
def slow_module(tmp_path, monkeypatch) -> str:
    """The name of a module (never imported in this process) whose import sleeps for a minute."""
    name = f"mazeslam_test_slow_import_{os.getpid()}_{next(_names)}"
    (tmp_path / f"{name}.py").write_text("import time\n\ntime.sleep(60)\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    return name


@pytest.fixture
def thread_errors(monkeypatch) -> list[BaseException]:
    """Exceptions that escape any thread during the test (the sender's must not)."""
    errors: list[BaseException] = []
    monkeypatch.setattr(threading, "excepthook", lambda hook: errors.append(hook.exc_value))
    return errors


def within(side: SideProcess, function: Callable, *args):
    """``function(*args)``'s value, failing the test if it has not returned within ``GUARD``
    seconds (the side process is then killed, which unblocks the write, and the thread ends)."""
    pid = side._process.pid if side._process is not None else None
    outcome: dict = {}

    def run():
        try:
            outcome["value"] = function(*args)
        except BaseException as error:  # handed to the test
            outcome["error"] = error

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    thread.join(GUARD)
    if thread.is_alive():
        if pid is not None:
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal.SIGKILL)
        thread.join(GUARD)
        pytest.fail(f"{getattr(function, '__name__', function)} hung (more than {GUARD} s)")
    if "error" in outcome:
        raise outcome["error"]
    return outcome["value"]


@contextlib.contextmanager
def guarded(modules=()):
    """``with SideProcess(modules)``, its exit under ``within``."""
    side = SideProcess(modules)
    try:
        yield side
    finally:
        within(side, side.__exit__, None, None, None)


def kill(side: SideProcess) -> None:
    """Kill the side process (SIGKILL, as the out-of-memory killer would) and reap it."""
    side._process.kill()
    side._process.join()


def test_a_large_call_gives_there_what_it_gives_here(thread_errors):
    with guarded() as side:
        within(side, side.start, digest, PAYLOAD)
        pid, *value = within(side, side.result)
    assert pid != os.getpid() and value == list(EXPECTED)
    assert not thread_errors


def test_a_large_call_to_a_killed_process_runs_here(thread_errors):
    with guarded() as side:
        kill(side)
        within(side, side.start, digest, PAYLOAD)
        assert within(side, side.result) == (os.getpid(), *EXPECTED)
        assert not side.running
    assert not thread_errors


def test_a_large_call_whose_write_is_blocked_runs_here_when_the_process_is_killed(slow_module, thread_errors):
    with guarded([slow_module]) as side:
        within(side, side.start, digest, PAYLOAD)  # returns at once: the thread writes
        assert side._sender is not None and side._sender.is_alive()  # 2 MiB cannot be in the pipe yet
        kill(side)
        assert within(side, side.result) == (os.getpid(), *EXPECTED)
        assert not side.running
        side.start(digest, b"after")  # the next call runs here too
        assert side.result() == (os.getpid(), *digest(b"after")[1:])
    assert not thread_errors


def test_leaving_without_the_result_while_a_write_is_blocked_does_not_hang(slow_module, thread_errors):
    side = SideProcess([slow_module])  # forked here, with no other thread running
    process = side._process

    def leave_without_result():
        with side:
            side.start(digest, PAYLOAD)
            assert side._sender.is_alive()  # blocked: the side process is still importing

    within(side, leave_without_result)
    assert not side.running and side._sender is None
    assert not process.is_alive()
    assert not thread_errors
