"""A second process that loads slow modules while this one works, then runs one call for it.

``mazeslam slam`` starts one before corner FastSLAM runs: it imports matplotlib (about 0.3 s) on the
other core while the filter runs, then draws ``slam.png`` and exports the map while this process
scores the run and writes the other outputs. It is forked (Linux), so it starts with everything
already imported here (fork it after the modules both need are loaded, or both load them); where fork
is not the platform's way (macOS, Windows), or the process cannot start, calls run in this process
instead, as they do when it has died. An error in the call is raised here, with the other process's
traceback as its cause. The process ignores Ctrl-C (this one handles it) and ends with this one,
however this one ends: leaving the ``with`` block (an error, Ctrl-C, ``Interrupted``) terminates it,
and when this process is killed outright (``kill -9``, SIGTERM without ``stop_on_signals``) it
notices and ends (``mazeslam.sweeps.pool.end_with_parent``), releasing its memory and the output
pipes it shares with this one.

``stop_on_signals`` turns SIGTERM (and SIGINT) into ``Interrupted``, an exception that unwinds this
process like Ctrl-C does (``with`` blocks end their processes, staging folders, locks) and then
exits with 128 + the signal's number (143, 130), as a process killed by it would report.
"""

from __future__ import annotations

import _thread
import contextlib
import importlib
import multiprocessing
import os
import signal
import sys
import threading
import traceback
from collections.abc import Callable, Iterator, Sequence
from multiprocessing.connection import Connection
from multiprocessing.reduction import ForkingPickler
from typing import Any

from mazeslam.core.outputs import stop_outputs
from mazeslam.sweeps.pool import end_with_parent


class RemoteTraceback(Exception):
    """The traceback of an error raised in the side process (the cause of the error raised here)."""


#: How long a side process told to stop (SIGTERM) gets before it is killed, s.
STOP_SECONDS = 2.0


class SideProcess:
    """One forked process that imports ``modules`` at once, then runs the calls given to ``start``,
    one at a time. Use as a context manager (the process ends on leaving it)."""

    def __init__(self, modules: Sequence[str] = (), fork: bool = True):
        self._connection: Connection | None = None
        self._process = None
        self._pending: tuple[Callable, tuple, dict] | None = None
        self._sender: threading.Thread | None = None
        self._send_failed = False
        if not fork or not sys.platform.startswith("linux"):
            return
        try:
            context = multiprocessing.get_context("fork")
            ours, theirs = context.Pipe()
            watch = (os.getpid(), threading.main_thread().ident)
            process = context.Process(target=_serve, args=(theirs, tuple(modules), ours, watch), daemon=True)
            process.start()
        except (OSError, ValueError):  # no fork, no pipes, no processes left: run calls here
            return
        theirs.close()
        self._connection, self._process = ours, process

    @classmethod
    def inline(cls) -> SideProcess:
        """No other process: each call runs here, in ``result``."""
        return cls(fork=False)

    @property
    def running(self) -> bool:
        """Whether calls go to the other process (else they run here)."""
        return self._process is not None

    def start(self, function: Callable, *args: Any, **kwargs: Any) -> None:
        """Hand ``function(*args, **kwargs)`` (picklable, module-level) to the other process; ``result``
        returns its value. Without the other process, nothing runs until ``result``.

        Returns at once: the call is pickled here (an error pickling it is raised here) and written
        to the pipe by a thread, since a call larger than the pipe's buffer (a log's scans, the
        figure's points) would otherwise hold this process until the other one reads it, which it
        does only once it has loaded its modules."""
        if self._pending is not None:
            raise RuntimeError("SideProcess.start: the last call's result was not collected")
        self._pending = function, args, kwargs
        if self._connection is not None:
            payload = ForkingPickler.dumps(self._pending)
            self._send_failed = False
            self._sender = threading.Thread(target=self._send, args=(self._connection, payload), daemon=True)
            self._sender.start()

    def _send(self, connection: Connection, payload: bytes) -> None:
        """Write a pickled call to the pipe (``start``'s thread)."""
        try:
            connection.send_bytes(payload)
        except (OSError, ValueError):  # it has died: the call runs here, in result()
            self._send_failed = True

    def result(self) -> Any:
        """The value of the call given to ``start`` (run here when the other process is not there)."""
        if self._pending is None:
            raise RuntimeError("SideProcess.result: no call was started")
        function, args, kwargs = self._pending
        self._pending = None
        if self._sender is not None:
            self._sender.join()
            self._sender = None
            if self._send_failed:
                self._stop()
        if self._connection is None:
            return function(*args, **kwargs)
        try:
            failed, value = self._connection.recv()
        except (EOFError, OSError):  # it died mid-call (killed, out of memory): do it here
            self._stop()
            return function(*args, **kwargs)
        if failed:
            error, remote = value
            raise error from RemoteTraceback(remote)
        return value

    def _stop(self) -> None:
        if self._process is not None:
            if self._process.is_alive():
                self._process.terminate()
            # A SIGTERM that lands while it imports its modules can be swallowed by an import's own
            # `except Exception`; then it waits for a call that never comes: SIGKILL ends it.
            self._process.join(timeout=STOP_SECONDS)
            if self._process.is_alive():
                self._process.kill()
                self._process.join()
            self._process = None
        if self._sender is not None:  # its write ends with the process
            self._sender.join()
            self._sender = None
        if self._connection is not None:
            self._connection.close()
            self._connection = None

    def __enter__(self) -> SideProcess:
        return self

    def __exit__(self, *exc_info) -> None:
        self._stop()


def _serve(connection: Connection, modules: tuple[str, ...], parents_end: Connection, watch: tuple) -> None:
    """The side process: import ``modules``, then run each call received until the pipe closes.

    It ends with its parent (``end_with_parent(*watch)``; it ignores Ctrl-C), and closes its copy of
    the parent's end of the pipe (``parents_end``, inherited by the fork): the parent's death closes
    the pipe, and a wait for the next call ends on it."""
    end_with_parent(*watch)
    parents_end.close()
    for name in modules:
        try:
            importlib.import_module(name)
        except ImportError:  # a call that needs it fails on it, and its error is raised in the caller
            pass
    while True:
        try:
            function, args, kwargs = connection.recv()
        except (EOFError, OSError):
            return
        try:
            reply: tuple[bool, Any] = (False, function(*args, **kwargs))
        except Exception as error:  # handed back to the caller, raised there
            reply = (True, (error, traceback.format_exc()))
        try:
            connection.send(reply)
        except OSError:  # the parent has gone (or closed its end): no one to answer
            return
        except Exception as error:  # the value or the error would not pickle: say so
            message = f"{type(error).__name__}: {error}"
            try:
                connection.send((True, (RuntimeError(f"side process: cannot hand back the result: {message}"), "")))
            except OSError:
                return


class Interrupted(SystemExit):
    """Raised in the main thread by a signal ``stop_on_signals`` handles. A ``SystemExit`` (exit
    status ``128 + signum``, 143 for SIGTERM, 130 for SIGINT): ``except Exception`` does not catch it,
    click lets it through, and ``with`` blocks and ``finally`` clauses run on its way out."""

    def __init__(self, signum: int):
        super().__init__(128 + signum)
        self.signum = signum

    @property
    def signal_name(self) -> str:
        return signal.Signals(self.signum).name


#: Seconds after which a stop is raised again in the main thread when it has not left
#: ``stop_on_signals``'s block: the first ``Interrupted`` can be swallowed by library code that
#: catches every exception (seen: raised inside numpy's lazy import of ``numpy.random``, after which
#: the run went on and ended with status 0). Longer than a clean stop's own cleanup takes (a side
#: process gets ``STOP_SECONDS``).
INSIST_SECONDS = 5.0


class _Stop:
    """The signal ``stop_on_signals`` received, raised as ``Interrupted`` until it leaves the block."""

    def __init__(self) -> None:
        self.signum: int | None = None
        self.repeating = False  # the next call of ``handle`` is ``insist``'s, not a signal's
        self.left = False

    def handle(self, signum: int, frame: object) -> None:
        """The signal handler: raise ``Interrupted``; a second signal (a clean stop that does not
        end) gets the default action, which kills the process, its children ending with it."""
        if self.repeating:
            self.repeating = False
        elif self.signum is not None:
            signal.signal(signum, signal.SIG_DFL)
            signal.raise_signal(signum)
            return
        self.signum = signum
        stop_outputs(Interrupted(signum))  # no result replaces the last run's, even if this one is swallowed
        timer = threading.Timer(INSIST_SECONDS, self.insist)
        timer.daemon = True
        timer.start()
        raise Interrupted(signum)

    def insist(self) -> None:
        """Raise the stop again in the main thread if it has not left the block (``INSIST_SECONDS``)."""
        if not self.left and self.signum is not None:
            self.repeating = True
            _thread.interrupt_main(signal.Signals(self.signum))


@contextlib.contextmanager
def stop_on_signals(signals: Sequence[int] = (signal.SIGTERM, signal.SIGINT)) -> Iterator[None]:
    """Within the block, each of ``signals`` raises ``Interrupted`` in the main thread; a second
    one gets the signal's default action (a clean stop that does not end kills the process, its
    children ending with it). A stop that some library swallowed is raised again after
    ``INSIST_SECONDS``, and a block that ends normally after a stop still ends in ``Interrupted``:
    a signalled command never reports success. The earlier handlers are restored on leaving.
    Outside the main thread (where Python cannot set handlers), and for a signal whose handler was
    set outside Python (which could not be put back), nothing changes."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    stop = _Stop()
    handled = [signum for signum in signals if signal.getsignal(signum) is not None]
    previous = {signum: signal.signal(signum, stop.handle) for signum in handled}
    try:
        yield
    except Interrupted:
        raise
    except SystemExit:  # click ends even a successful command with SystemExit(0)
        if stop.signum is not None:  # a stop was raised and swallowed on its way up
            raise Interrupted(stop.signum) from None
        raise
    else:
        if stop.signum is not None:
            raise Interrupted(stop.signum)
    finally:
        stop.left = True
        stop_outputs(None)
        for signum, handler in previous.items():
            signal.signal(signum, handler)
