"""``map_parallel``: one function over many calls on local worker processes, the results in the
order of the calls. The experiments' scripts run their parallel work through it (a sweep's runs
go through ``mazeslam.sweeps.runner`` instead).

Also what keeps a child process from outliving its parent (``end_with_parent``, ``ends_with_this_process``):
a parent killed outright (``kill -9``, the out-of-memory killer) runs no clean-up, and its workers,
waiting on queues that their siblings hold open, would wait for ever. Every child this package and
the command line start (a sweep's workers, ``map_parallel``'s, ``mazeslam slam``'s side process)
watches its parent and ends when it does.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import sys
import threading
import time
from collections.abc import Callable, Sequence
from typing import Any

#: Seconds between a child's checks that its parent is alive, where the kernel does not tell it at once.
PARENT_POLL_SECONDS = 0.25
#: ``prctl``'s option that sets the signal a process receives when its parent dies (linux/prctl.h).
PR_SET_PDEATHSIG = 1


def map_parallel(
    function: Callable[..., Any],
    calls: Sequence[tuple],
    workers: int | None = None,
    *,
    progress: bool = False,
    fresh_process: bool = False,
    on_result: Callable[[int, Any], None] | None = None,
) -> list:
    """``[function(*arguments) for arguments in calls]``, computed on ``workers`` local processes.

    Each call runs as it would alone: a call that seeds its own random draws gives the same result
    here as in a loop, whatever the number of workers.

    Args:
        function: a module-level function (the worker processes receive it pickled, by name).
        calls: the positional arguments of each call, one tuple per call (``(seed,)`` for a call
            of one argument); N calls.
        workers: processes at once, default one per CPU (``os.cpu_count()``); never more than N.
            1 runs the calls in this process, one after the other (unless ``fresh_process``).
        progress: draw a progress bar of the finished calls.
        fresh_process: each call in a process of its own, started for it and ended after it
            (``multiprocessing.Pool(maxtasksperchild=1)``): a call's peak memory is its own, and
            nothing a call leaves behind reaches the next.
        on_result: ``on_result(index, result)`` here as each call finishes, in the order they
            finish (``index``: the call's place in ``calls``), e.g. to print rows as they come.

    Returns:
        The N results, in the order of ``calls``. A call that raises raises here (the calls still
        running are then stopped).
    """
    calls = list(calls)
    if not calls:
        return []
    processes = max(1, min(workers or os.cpu_count() or 1, len(calls)))
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=len(calls), unit="run")
    results: list = [None] * len(calls)

    def done(index: int, result: Any) -> None:
        results[index] = result
        if on_result is not None:
            on_result(index, result)
        if bar is not None:
            bar.update()

    try:
        if processes == 1 and not fresh_process:
            for index, arguments in enumerate(calls):
                done(index, function(*arguments))
        else:
            jobs = [(index, function, tuple(arguments)) for index, arguments in enumerate(calls)]
            fresh = 1 if fresh_process else None
            with multiprocessing.Pool(processes, maxtasksperchild=fresh, **ends_with_this_process()) as pool:
                for index, result in pool.imap_unordered(_indexed_call, jobs):
                    done(index, result)
    finally:
        if bar is not None:
            bar.close()
    return results


def _indexed_call(job: tuple[int, Callable[..., Any], tuple]) -> tuple[int, Any]:
    """One call of ``map_parallel`` in a worker: ``(index, function(*arguments))``."""
    index, function, arguments = job
    return index, function(*arguments)


def ends_with_this_process() -> dict[str, Any]:
    """``initializer`` and ``initargs`` for a pool (``multiprocessing.Pool``, ``ProcessPoolExecutor``)
    whose workers end when this process ends, however it ends: ``Pool(n, **ends_with_this_process())``."""
    return {"initializer": end_with_parent, "initargs": (os.getpid(), threading.main_thread().ident)}


def end_with_parent(parent: int, parent_main_thread: int | None = None) -> None:
    """Run first thing in a child process (a pool's initializer, a forked process's target) started by
    process ``parent``: the child ends as soon as ``parent`` does, even when ``parent`` is killed with
    no chance to stop it, and it leaves Ctrl-C to ``parent``.

    - SIGINT is ignored: Ctrl-C in a terminal reaches every process of the group, and the parent's
      clean stop ends its children (each a traceback of its own otherwise). SIGTERM gets its default
      action back (a fork inherits the parent's Python handler): ``terminate()`` ends the child.
    - On Linux, when forked by the parent's main thread (``parent_main_thread``, its
      ``threading.get_ident()``), the kernel sends the child SIGTERM when the parent dies
      (``prctl(PR_SET_PDEATHSIG)``): at once, even while the child is deep in a computation. The
      signal comes on the death of the *thread* that forked, hence main threads only (a pool's
      replacement workers are forked by one of its threads, which may end before the process does).
    - Otherwise a daemon thread checks every ``PARENT_POLL_SECONDS`` that the child's parent is still
      ``parent`` (an orphan is handed to another process) and ends the child when it is not. A child
      started through another process (a fork server) checks instead that ``parent`` still exists.
    - A parent that died before this ran: the child ends here.

    Nothing is watched where signals are not POSIX's (Windows)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    if os.name != "posix":
        return
    direct = os.getppid() == parent
    if direct and parent_main_thread == threading.get_ident() and _parent_death_signal(signal.SIGTERM):
        if os.getppid() != parent:  # it died before the kernel was told to watch it
            os._exit(1)
        return
    if not _parent_alive(parent, direct):
        os._exit(1)
    threading.Thread(target=_watch_parent, args=(parent, direct), name="watch-parent", daemon=True).start()


def _parent_death_signal(signum: int) -> bool:
    """Ask Linux to send this process ``signum`` when its parent dies; whether it could."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        import ctypes

        return ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, int(signum), 0, 0, 0) == 0
    except (OSError, AttributeError):  # no C library to load, or no prctl in it
        return False


def _parent_alive(parent: int, direct: bool) -> bool:
    """Whether ``parent`` lives: still this process's parent (``direct``), else a process that exists."""
    if direct:
        return os.getppid() == parent
    try:
        os.kill(parent, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # it exists, as another user's process (its pid reused)
        return True
    return True


def _watch_parent(parent: int, direct: bool) -> None:
    """``end_with_parent``'s thread: end this process (at once, nothing to clean up that its parent
    still needs) when ``parent`` has gone."""
    while _parent_alive(parent, direct):
        time.sleep(PARENT_POLL_SECONDS)
    os._exit(1)
