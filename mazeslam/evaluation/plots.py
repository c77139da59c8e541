"""Figures: a simulated run (walls, corners, true and estimated paths), and saving any figure alike."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # draw to files; no display needed
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def plot_run(
    path: str | Path,
    walls: np.ndarray,
    corners: np.ndarray,
    truth: np.ndarray,
    estimates: dict[str, np.ndarray],
    title: str = "",
) -> Path:
    """Save a top-down figure of a run to ``path`` (PNG, PDF, ... by suffix).

    Args:
        walls: (W, 4) wall surfaces ``[x1, y1, x2, y2]``, metres, world frame.
        corners: (K, 2) true corners.
        truth: (R, 3) true poses.
        estimates: name -> (R, 3) estimated poses, e.g. ``{"dead reckoning": ...}``.
    """
    fig, ax = plt.subplots(figsize=(9, 7))
    for x1, y1, x2, y2 in walls:
        ax.plot([x1, x2], [y1, y2], color="0.25", linewidth=1.5)
    if len(corners):
        ax.plot(corners[:, 0], corners[:, 1], "o", color="tab:green", markersize=4, label="true corners")
    ax.plot(truth[:, 0], truth[:, 1], color="black", linewidth=1.2, label="true path")
    for (name, poses), colour in zip(estimates.items(), ("tab:red", "tab:blue", "tab:orange", "tab:purple")):
        ax.plot(poses[:, 0], poses[:, 1], "--", color=colour, linewidth=1.0, label=name)
    ax.plot(*truth[0, :2], "k^", markersize=8, label="start")
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    return save_figure(fig, ax, path, title)


def save_figure(fig, ax, path: str | Path, title: str = "") -> Path:
    """Title ``ax``, put its legend right of the plot, save ``fig`` to ``path`` (folders made) and close it."""
    ax.set_title(title)
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path
