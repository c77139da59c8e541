"""``map_parallel``: the results of every call in the order of the calls, whatever the workers."""

import os

import numpy as np
import pytest

from mazeslam.sweeps.pool import map_parallel


def draw(seed: int, size: int) -> float:
    """A seeded random draw: the same arguments give the same number in any process."""
    return float(np.random.default_rng(seed).normal(size=size).sum())


def process_id(_: int) -> int:
    return os.getpid()


def fail_on(value: int) -> int:
    if value == 2:
        raise ValueError(f"call {value} fails")
    return value


@pytest.mark.parametrize("workers", [1, 2])
def test_results_come_in_the_order_of_the_calls(workers):
    calls = [(seed, 10 + seed) for seed in range(6)]
    finished = []
    results = map_parallel(draw, calls, workers, on_result=lambda index, result: finished.append((index, result)))
    assert results == [draw(*call) for call in calls]
    assert sorted(finished) == list(enumerate(results))


def test_one_worker_runs_here_and_fresh_processes_are_one_per_call():
    assert map_parallel(process_id, [(0,), (1,)], workers=1) == [os.getpid()] * 2
    fresh = map_parallel(process_id, [(0,), (1,), (2,)], workers=1, fresh_process=True)
    assert len(set(fresh)) == 3 and os.getpid() not in fresh


def test_no_calls_and_a_failing_call():
    assert map_parallel(draw, []) == []
    with pytest.raises(ValueError, match="call 2 fails"):
        map_parallel(fail_on, [(0,), (1,), (2,), (3,)], workers=2)
