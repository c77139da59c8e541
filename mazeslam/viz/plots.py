"""Figures: a simulated run (walls, corners, true and estimated paths), and saving any figure alike.

Every figure has labelled axes with units, a legend and a title; ``save_figure`` puts the legend
below the plot and lays the figure out with matplotlib's constrained layout, so neither the legend
nor an axis label is cut off. Many similar items (walls, ellipses, points) go into one collection
each, not one artist per item, so a figure of thousands of scan points draws in a fraction of a second.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.collections import EllipseCollection, LineCollection

from mazeslam.core.outputs import written
from mazeslam.viz.backends import close_figure, file_figure


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
    fig = file_figure(figsize=(8, 7.5))
    ax = fig.subplots()
    draw_walls(ax, walls, colour="0.25", linewidth=1.5)
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


def draw_walls(ax, walls: np.ndarray | None, colour="0.6", linewidth: float = 1.0, label: str | None = "walls") -> None:
    """Wall segments (W, 4) ``[x1, y1, x2, y2]`` as one collection (nothing when None or empty)."""
    if walls is None or not len(walls):
        return
    ax.add_collection(
        LineCollection(
            list(np.asarray(walls, float).reshape(-1, 2, 2)), colors=colour, linewidths=linewidth, label=label
        ),
        autolim=True,
    )
    ax.autoscale_view()


def draw_ellipses(
    ax, means: np.ndarray, covariances: np.ndarray, sigmas: float = 2.0, colour="tab:purple"
) -> EllipseCollection | None:
    """The ``sigmas``-sigma ellipses of 2-D Gaussians (L, 2), (L, 2, 2) as one collection (returned;
    None when there are none)."""
    means = np.asarray(means, float).reshape(-1, 2)
    if not len(means):
        return None
    values, vectors = np.linalg.eigh(np.asarray(covariances, float).reshape(-1, 2, 2))
    # eigh sorts ascending: the major axis is the last eigenvector.
    angles = np.degrees(np.arctan2(vectors[:, 1, 1], vectors[:, 0, 1]))
    widths = 2 * sigmas * np.sqrt(np.maximum(values[:, 1], 0))
    heights = 2 * sigmas * np.sqrt(np.maximum(values[:, 0], 0))
    return ax.add_collection(
        EllipseCollection(
            widths,
            heights,
            angles,
            units="xy",
            offsets=means,
            offset_transform=ax.transData,
            facecolors="none",
            edgecolors=colour,
            linewidths=0.8,
        )
    )


def mark_start(ax, poses: np.ndarray, colour: str) -> None:
    """A hollow circle at the first of ``poses`` (R, 3) (world frame, m), labelled "start"."""
    ax.plot(*poses[0, :2], "o", color=colour, markerfacecolor="white", markersize=8, label="start", zorder=5)


def mark_end(ax, poses: np.ndarray, colour: str) -> None:
    """An outlined square at the last of ``poses`` (R, 3), labelled "end", drawn over what lies
    there (the particles gather where a path ends)."""
    ax.plot(
        *poses[-1, :2],
        "s",
        color=colour,
        markerfacecolor="none",
        markeredgewidth=2,
        markersize=9,
        label="end",
        zorder=6,
    )


def save_figure(fig, ax, path: str | Path, title: str = "", legend_columns: int = 4, dpi: int = 120) -> Path:
    """Title ``ax``, put its legend below the plot, lay ``fig`` out (constrained layout, so neither
    the legend nor an axis label is cut off), save it to ``path`` (folders made; whole or not at
    all, ``mazeslam.core.outputs.written``) and close it, saved or not (``close_figure``)."""
    ax.set_title(title)
    fig.set_layout_engine("constrained")
    handles, labels = ax.get_legend_handles_labels()
    if handles:
        fig.legend(handles, labels, loc="outside lower center", ncol=min(legend_columns, len(handles)), fontsize=8)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        with written(path) as temporary:
            fig.savefig(temporary, dpi=dpi)
    finally:
        close_figure(fig)
    return path
