"""Worker processes end with their parent: a parent killed outright (``kill -9``) leaves no worker
running (``end_with_parent``, both ways it watches: the kernel's parent-death signal and the polling
thread), ``map_parallel``'s pool included; and a sweep's local pool left by an exception ends its
workers at once instead of waiting for the calls they are running.

Processes are checked in ``/proc`` (Linux): a process is running while it exists and is not a
zombie (a dead orphan waits there for its new parent to collect it)."""

import subprocess
import sys
import textwrap
import time

import pytest
from conftest import PROJECT_ROOT
from processes import ended_within, kill_all, running

from mazeslam.sweeps.runner import _local_pool

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="processes are read in /proc (Linux)")

#: Seconds a killed parent's children have to end (about 0.3 s on a quiet machine, at most the
#: polling thread's 0.25 s after the kernel's signal; generous for a loaded CI machine).
GRACE = 5.0


def start_script(code: str) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-c", textwrap.dedent(code)], stdout=subprocess.PIPE, text=True, cwd=PROJECT_ROOT
    )


def read_pids(process: subprocess.Popen, count: int) -> list[int]:
    """The first ``count`` lines the script and its children print, each a process id."""
    assert process.stdout is not None
    return [int(process.stdout.readline()) for _ in range(count)]


@pytest.mark.parametrize("watch", ["kernel", "thread"])
def test_a_child_ends_when_its_parent_is_killed(watch):
    """``kernel``: forked by the parent's main thread (PR_SET_PDEATHSIG); ``thread``: the polling
    thread (a child forked by another thread; told so here by giving no main thread)."""
    script = start_script(
        f"""
        import multiprocessing, os, threading, time
        from mazeslam.sweeps.pool import end_with_parent

        def child(parent, main_thread):
            end_with_parent(parent, main_thread)
            os.write(1, f"{{os.getpid()}}\\n".encode())  # one write, as in the test below
            time.sleep(60)

        if __name__ == "__main__":
            main_thread = threading.main_thread().ident if {watch == "kernel"} else None
            multiprocessing.get_context("fork").Process(target=child, args=(os.getpid(), main_thread)).start()
            time.sleep(60)
        """
    )
    (child,) = read_pids(script, 1)
    try:
        assert running(child)
        script.kill()
        script.wait()
        assert ended_within([child], GRACE)
    finally:
        kill_all([child])


def test_map_parallel_workers_end_when_the_script_is_killed():
    script = start_script(
        """
        import os, time
        from mazeslam.sweeps.pool import map_parallel

        def busy(_):
            os.write(1, f"{os.getpid()}\\n".encode())  # one write: two workers share the pipe
            time.sleep(60)

        if __name__ == "__main__":
            map_parallel(busy, [(0,), (1,)], workers=2)
        """
    )
    workers = read_pids(script, 2)
    try:
        script.kill()
        script.wait()
        assert ended_within(workers, GRACE)
    finally:
        kill_all(workers)


class Stop(Exception):
    pass


def test_a_sweep_pool_left_by_an_exception_ends_its_workers_at_once():
    """Without it, leaving the pool would wait the 60 s of the call its worker is running."""
    began = time.monotonic()
    with pytest.raises(Stop), _local_pool(2) as pool:
        assert pool is not None
        future = pool.submit(time.sleep, 60)
        while not future.running():
            time.sleep(0.01)
        workers = list(pool._processes)
        raise Stop
    assert ended_within(workers, GRACE)
    assert time.monotonic() - began < 10
