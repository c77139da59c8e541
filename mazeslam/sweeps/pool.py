"""``map_parallel``: one function over many calls on local worker processes, the results in the
order of the calls. The experiments' scripts run their parallel work through it (a sweep's runs
go through ``mazeslam.sweeps.runner`` instead)."""

from __future__ import annotations

import multiprocessing
import os
from collections.abc import Callable, Sequence
from typing import Any


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
            with multiprocessing.Pool(processes, maxtasksperchild=1 if fresh_process else None) as pool:
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
