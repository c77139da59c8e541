"""The pose graph's figure (``smooth.png`` of a laser log): its map, its nodes and its edges."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mazeslam.data.map_io import OccupancyMap


def _segments(poses: np.ndarray, pairs: np.ndarray) -> np.ndarray:
    """The line segments (2, E * 3) between the positions of ``poses`` (S, 3) named by ``pairs``
    (E, 2), each followed by a NaN break, as one ``plot`` call draws them."""
    ends = poses[np.asarray(pairs, dtype=int).reshape(-1, 2), :2]  # (E, 2, 2)
    breaks = np.full((len(ends), 1, 2), np.nan)
    return np.concatenate([ends, breaks], axis=1).reshape(-1, 2).T


def plot_pose_graph(
    path: str | Path,
    occupancy: OccupancyMap,
    poses: np.ndarray,
    kept: np.ndarray,
    rejected: np.ndarray,
    title: str,
    reference: np.ndarray | None = None,
    reference_label: str = "reference path",
) -> Path:
    """Draw the map ``occupancy`` (world frame, metres) with the graph's nodes ``poses`` (S, 3)
    joined in order (its sequential edges), the loop closures the solve kept, ``kept`` (K, 2) pairs
    of node indexes, and those it rejected, ``rejected`` (F, 2); and ``reference`` (S, 3) when given.
    Saved to ``path``."""
    from mazeslam.viz.backends import file_figure
    from mazeslam.viz.grid_figure import draw_occupancy
    from mazeslam.viz.plots import mark_end, mark_start, save_figure

    fig = file_figure(figsize=(9, 7))
    ax = fig.subplots()
    if draw_occupancy(ax, occupancy):
        ax.plot([], [], "s", color="black", label="occupied cells (scans at the graph's poses)")
    if reference is not None:
        ax.plot(reference[:, 0], reference[:, 1], color="tab:green", lw=1.0, label=reference_label)
    ax.plot(poses[:, 0], poses[:, 1], color="tab:blue", lw=0.9, label="sequential edges")
    ax.plot(poses[:, 0], poses[:, 1], ".", color="tab:blue", ms=2, label=f"nodes ({len(poses)} scans)")
    if len(kept):
        ax.plot(*_segments(poses, kept), color="tab:orange", lw=0.8, label=f"loop closures kept ({len(kept)})")
    if len(rejected):
        ax.plot(
            *_segments(poses, rejected), color="red", lw=0.8, ls=":", label=f"loop closures rejected ({len(rejected)})"
        )
    mark_start(ax, poses, "tab:blue")
    mark_end(ax, poses, "tab:blue")
    ax.set(xlabel="x [m]", ylabel="y [m]", aspect="equal")
    return save_figure(fig, ax, path, title, legend_columns=3)
