"""The exercise's test_corner figure: range points, extracted lines in various colours, corners in green."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from mazeslam.evaluation.plots import save_figure  # noqa: E402
from mazeslam.filters.corners import ScanFeatures  # noqa: E402

KIND_STYLE = {
    "corner": dict(marker="o", color="tab:green", label="corner"),
    "wall_end": dict(marker="s", color="tab:green", label="wall end"),
    "occluded": dict(marker="x", color="tab:red", label="occluded end"),
    "gap": dict(marker="x", color="tab:orange", label="end at a gap"),
    "edge": dict(marker="x", color="tab:purple", label="end at the field of view"),
    "junction": dict(marker="+", color="tab:brown", label="junction"),
}


def draw_scan(ax, features: ScanFeatures, mount=(0.0, 0.0), true_corners: np.ndarray | None = None) -> None:
    """Draw one scan's features on ``ax`` in the robot frame (metres)."""
    mount = np.asarray(mount, dtype=float)
    points = features.points + mount
    ax.plot(points[:, 0], points[:, 1], ".", color="black", markersize=2, label="range points")
    colours = plt.get_cmap("tab10")
    for i, segment in enumerate(features.segments):
        ends = np.array([segment.start, segment.end]) + mount
        ax.plot(ends[:, 0], ends[:, 1], "-", color=colours(i % 10), linewidth=2)
    shown = set()
    for observation in features.observations:
        style = dict(KIND_STYLE[observation.kind])
        label = style.pop("label")
        ax.plot(
            observation.x,
            observation.y,
            linestyle="none",
            markersize=7,
            markerfacecolor="none",
            markeredgewidth=1.5,
            label=None if label in shown else label,
            **style,
        )
        shown.add(label)
    if true_corners is not None and len(true_corners):
        ax.plot(true_corners[:, 0], true_corners[:, 1], "k+", markersize=9, label="true corners")
    ax.plot(0, 0, ">", color="tab:blue", markersize=9, label="robot (faces +x)")
    ax.set_aspect("equal")
    ax.set_xlabel("x forward [m]")
    ax.set_ylabel("y left [m]")


def plot_scan(
    path: str | Path, features: ScanFeatures, mount=(0.0, 0.0), title: str = "", true_corners: np.ndarray | None = None
) -> Path:
    """Save the figure of one scan (robot frame) to ``path``."""
    fig, ax = plt.subplots(figsize=(8, 7))
    draw_scan(ax, features, mount, true_corners)
    return save_figure(fig, ax, path, title)
