"""docs/img/maze_env.png: mazeslam/Maze-v0 with the frontier agent and online FastSLAM, as a figure
(axes in metres, legend, title) around the environment's own picture (``env.render()``).

    python scripts/figures/maze_env.py [--out docs/img/maze_env.png] [--steps 600] [--seed 0]
"""

from __future__ import annotations

import argparse
import importlib.util
from pathlib import Path

import gymnasium as gym
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402
from matplotlib.patches import Patch  # noqa: E402

import mazeslam  # noqa: E402, F401  (registers the environments)
from mazeslam.viz.plots import save_figure  # noqa: E402
from mazeslam.envs.online_slam import OnlineFastSLAM  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
MARGIN = 0.02  # metres around the maze in the environment's picture (envs/rendering.py)


def frontier_agent_class():
    """``FrontierAgent`` from examples/frontier_agent.py (an example, not part of the package)."""
    spec = importlib.util.spec_from_file_location("frontier_agent", ROOT / "examples" / "frontier_agent.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.FrontierAgent


def main(out: Path, steps: int, seed: int) -> Path:
    env = OnlineFastSLAM(gym.make("mazeslam/Maze-v0", rows=4, cols=4, render_mode="rgb_array"))
    observation, info = env.reset(seed=seed)
    agent = frontier_agent_class()(env)
    for _ in range(steps):
        observation, _, terminated, truncated, info = env.step(agent(observation, info))
        if terminated or truncated:
            break
    image = env.render()
    base = env.unwrapped
    width, height = base.maze.cols * base.maze.cell_size, base.maze.rows * base.maze.cell_size
    fig, ax = plt.subplots(figsize=(7, 7.6))
    ax.imshow(image, extent=(-MARGIN, width + MARGIN, -MARGIN, height + MARGIN))
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    legend = [
        Patch(color="#dfeedd", label="cells visited"),
        Line2D([], [], color="0.75", linewidth=1.5, label="walls"),
        Line2D([], [], marker=".", linestyle="none", color="0.15", label="wall seen by the laser"),
        Line2D([], [], color="tab:red", linewidth=0.6, label="laser rays (about 60 of them)"),
        Line2D([], [], marker="o", linestyle="none", color="tab:blue", markersize=9, label="robot (white: heading)"),
        Line2D([], [], marker=".", linestyle="none", color="red", label="FastSLAM particles"),
        Line2D([], [], marker="+", linestyle="none", color="tab:purple", markersize=8, label="FastSLAM landmarks"),
    ]
    fig.set_layout_engine("constrained")
    fig.legend(handles=legend, loc="outside lower center", ncol=3, fontsize=8)
    title = (
        f"mazeslam/Maze-v0, 4 x 4 maze, seed {seed}: the frontier agent after {info['time']:.0f} s\n"
        f"with online FastSLAM; cells visited {info['visited']:.0%}, walls seen {info['coverage']:.0%}"
    )
    env.close()
    return save_figure(fig, ax, out, title)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "img" / "maze_env.png")
    parser.add_argument("--steps", type=int, default=600, help="agent steps (0.1 s each) before the picture")
    parser.add_argument("--seed", type=int, default=0)
    arguments = parser.parse_args()
    print(main(arguments.out, arguments.steps, arguments.seed))
