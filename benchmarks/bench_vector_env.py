"""Benchmark: the vector env of mazeslam/Maze-v0 (``MazeVectorEnv``, batched numpy physics, one ray
cast for all robots), aggregate steps/s at 1, 8, 64 and 256 envs (16 x 16 mazes, 180 beams, random
actions, one process), against the same number of single envs (pymunk) in ``SyncVectorEnv``; and
the single env (``gym.make``, pymunk) against ir-sim stepping one comparable robot in the same maze
(``bench_env.irsim_rate``); all in the same run, each rate the best of ``REPEATS`` interleaved
timings (the machine is shared). ir-sim is pinned (``bench_env.IRSIM_VERSION``) and installed with
pip when missing; if it cannot be, its columns say why it was skipped.
Targets (issue 21): 64 envs at least 20 000 steps/s and 10x ``SyncVectorEnv``; the single env at
least 20x ir-sim.
Run: ``python benchmarks/bench_vector_env.py`` (``--no-install``: never install ir-sim;
``--cpu-time``: rates per second of CPU time, see ``bench_env``).
"""

from __future__ import annotations

import gymnasium as gym
from bench_env import IRSIM_VERSION, clock, clock_name, irsim_comparison, mazeslam_rate

import mazeslam  # noqa: F401  (registers the environments)
from mazeslam.sim.maze import generate_maze

ROWS = COLS = 16
SIZES = (1, 8, 64, 256)
#: Vector steps timed per size (the batched env; SyncVectorEnv gets fewer, it is slower).
VECTOR_STEPS = {1: 2000, 8: 1000, 64: 300, 256: 100}
SYNC_STEPS = {1: 600, 8: 150, 64: 40, 256: 12}
IRSIM_STEPS = 200
REPEATS = 3
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
    began = clock()
    for action in actions[3:]:
        envs.step(action)
    elapsed = clock() - began
    envs.close()
    return num_envs * steps / elapsed


def best_of(measure, repeats: int = REPEATS) -> float:
    """The highest of ``repeats`` calls of ``measure()`` (the one least slowed by other work)."""
    return max(measure() for _ in range(repeats))


def single_env_row(maze, irsim: float | None, skipped: str | None) -> dict:
    """The single env (pymunk ``MazeEnv``) in ``maze`` against ir-sim's rate there."""
    single = best_of(lambda: mazeslam_rate(maze))
    row: dict = {"benchmark": f"single env (gym.make), {ROWS}x{COLS}, 180 beams", "steps_per_s": single}
    if irsim is None:
        row["irsim"] = f"skipped: {skipped}"
    else:
        row.update({"irsim_steps_per_s": irsim, "ratio_to_irsim": single / irsim})
        row["met"] = single / irsim >= TARGET_IRSIM_RATIO_1
    return row


def vector_row(size: int, irsim: float | None) -> dict:
    """``size`` envs in the vector env and in ``SyncVectorEnv``, timed in turns."""
    ours, sync = 0.0, 0.0
    for _ in range(REPEATS):
        ours = max(ours, aggregate_rate("vector_entry_point", size, VECTOR_STEPS[size]))
        sync = max(sync, aggregate_rate("sync", size, SYNC_STEPS[size]))
    row = {
        "benchmark": f"vector env, {size} envs, {ROWS}x{COLS}, 180 beams",
        "steps_per_s": ours,
        "sync_steps_per_s": sync,
        "ratio_to_sync": ours / sync,
        "ratio_to_irsim": ours / irsim if irsim else float("nan"),
    }
    if size == 64:
        row["met"] = ours >= TARGET_RATE_64 and ours / sync >= TARGET_RATIO_64
    return row


def run() -> list[dict]:
    maze = generate_maze(ROWS, COLS, 0)
    irsim, skipped = irsim_comparison(maze, IRSIM_STEPS)
    if irsim is not None:
        irsim = max(irsim, *(irsim_comparison(maze, IRSIM_STEPS)[0] or 0.0 for _ in range(REPEATS - 1)))
    print(
        f"ir-sim {IRSIM_VERSION}, one env:",
        f"{irsim:.0f} steps/s" if irsim is not None else f"skipped: {skipped}",
        flush=True,
    )
    rows = [single_env_row(maze, irsim, skipped)]
    for size in SIZES:
        rows.append(vector_row(size, irsim))
    for row in rows:
        print(
            ", ".join(
                f"{key} {value:.4g}" if isinstance(value, float) else f"{key} {value}" for key, value in row.items()
            ),
            flush=True,
        )
    return rows


if __name__ == "__main__":
    import pandas as pd

    table = pd.DataFrame(run()).set_index("benchmark")
    print(table.to_markdown(floatfmt=".4g"))
    print(
        f"targets: 64 envs >= {TARGET_RATE_64:.0f} steps/s and >= {TARGET_RATIO_64:.0f}x sync; "
        f"single env >= {TARGET_IRSIM_RATIO_1:.0f}x ir-sim {IRSIM_VERSION}; rates per second of {clock_name()}"
    )
