"""Benchmark: the vector env of mazeslam/Maze-v0 (``MazeVectorEnv``, batched numpy physics, one ray
cast for all robots), aggregate steps/s at 1, 8, 64 and 256 envs (16 x 16 mazes, 180 beams, random
actions, one process), against the same number of single envs (pymunk) in ``SyncVectorEnv`` and
against ir-sim 2.12 stepping one comparable robot in the same maze (``bench_env.irsim_rate``), all in
the same run. ir-sim is optional (``pip install ir-sim==2.12.0``); without it its column says skipped.
Targets: 64 envs at least 20 000 steps/s and 10x ``SyncVectorEnv``; one env at least 20x ir-sim.
Run: ``python benchmarks/bench_vector_env.py``.
"""

from __future__ import annotations

import time

import gymnasium as gym
from bench_env import irsim_rate

import mazeslam  # noqa: F401  (registers the environments)
from mazeslam.envs.maze import generate_maze

ROWS = COLS = 16
SIZES = (1, 8, 64, 256)
#: Vector steps timed per size (the batched env; SyncVectorEnv gets fewer, it is slower).
VECTOR_STEPS = {1: 2000, 8: 1000, 64: 300, 256: 100}
SYNC_STEPS = {1: 600, 8: 150, 64: 20, 256: 6}
TARGET_RATE_64, TARGET_RATIO_64, TARGET_IRSIM_RATIO_1 = 20_000.0, 10.0, 20.0


def aggregate_rate(mode: str, num_envs: int, steps: int) -> float:
    """Env steps per second of ``make_vec(..., vectorization_mode=mode)`` under random actions,
    after a few warm-up steps (the first reset draws every maze)."""
    envs = gym.make_vec(
        "mazeslam/Maze-v0", num_envs=num_envs, vectorization_mode=mode, rows=ROWS, cols=COLS, max_steps=100_000
    )
    envs.reset(seed=0)
    envs.action_space.seed(0)
    actions = [envs.action_space.sample() for _ in range(steps + 3)]
    for action in actions[:3]:
        envs.step(action)
    began = time.perf_counter()
    for action in actions[3:]:
        envs.step(action)
    elapsed = time.perf_counter() - began
    envs.close()
    return num_envs * steps / elapsed


def run() -> list[dict]:
    irsim = irsim_rate(generate_maze(ROWS, COLS, 0))
    print(
        "ir-sim 2.12 single env:",
        f"{irsim:.0f} steps/s" if irsim else "skipped: ir-sim is not installed (pip install ir-sim==2.12.0)",
        flush=True,
    )
    rows = []
    for size in SIZES:
        ours = aggregate_rate("vector_entry_point", size, VECTOR_STEPS[size])
        sync = aggregate_rate("sync", size, SYNC_STEPS[size])
        row = {
            "benchmark": f"vector env, {size} envs, {ROWS}x{COLS}, 180 beams",
            "steps_per_s": ours,
            "sync_steps_per_s": sync,
            "ratio_to_sync": ours / sync,
            "ratio_to_irsim": ours / irsim if irsim else float("nan"),
        }
        if size == 64:
            row["met"] = ours >= TARGET_RATE_64 and ours / sync >= TARGET_RATIO_64
        if size == 1 and irsim:
            row["met"] = ours / irsim >= TARGET_IRSIM_RATIO_1
        print(
            ", ".join(
                f"{key} {value:.4g}" if isinstance(value, float) else f"{key} {value}" for key, value in row.items()
            ),
            flush=True,
        )
        rows.append(row)
    return rows


if __name__ == "__main__":
    import pandas as pd

    table = pd.DataFrame(run()).set_index("benchmark")
    print(table.to_markdown(floatfmt=".4g"))
    print(
        f"targets: 64 envs >= {TARGET_RATE_64:.0f} steps/s and >= {TARGET_RATIO_64:.0f}x sync; "
        f"1 env >= {TARGET_IRSIM_RATIO_1:.0f}x ir-sim"
    )
