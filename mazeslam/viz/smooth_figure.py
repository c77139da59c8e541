"""The batch optimum's figure (``smooth.png``): its map, scan points placed by its poses, its path."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mazeslam.core.motion import dead_reckoning
from mazeslam.data.loaded_run import LoadedRun
from mazeslam.smoothing.optimum import Smoothed


def plot_smoothed(path, run: LoadedRun, smoothed: Smoothed, points: np.ndarray) -> Path:
    """The slam figure for the optimum: its map with 2-sigma ellipses, scan points placed by its poses,
    its path beside dead reckoning; with the sidecars, the walls, true path and true corners."""
    from mazeslam.viz.backends import file_figure
    from mazeslam.viz.plots import draw_ellipses, save_figure

    fig = file_figure(figsize=(9, 7))
    ax = fig.subplots()
    for x1, y1, x2, y2 in run.walls if run.walls is not None else []:
        ax.plot([x1, x2], [y1, y2], color="0.6", linewidth=1.0)
    if len(points):
        ax.plot(*points.T, ".", color="black", markersize=0.8, alpha=0.4, label="scan points")
    paths = {
        "dead reckoning": (dead_reckoning(run.log, run.start_pose), "0.5"),
        "batch optimum": (smoothed.poses, "tab:blue"),
    }
    if run.truth is not None:
        paths[run.truth_path_label] = (run.truth, "tab:green")
    for label, (poses, colour) in paths.items():
        ax.plot(poses[:, 0], poses[:, 1], color=colour, linewidth=1.2, label=label)
    if len(run.true_corners):
        ax.plot(
            *run.true_corners.T, "o", color="tab:green", markersize=4, markerfacecolor="none", label="true landmarks"
        )
    result = smoothed.result
    draw_ellipses(ax, result.landmarks, result.landmark_covariances)
    if len(result.landmarks):
        ax.plot(*result.landmarks.T, "+", color="tab:purple", markersize=8, label="landmarks (2 sigma)")
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    title = f"{run.path.name}: batch optimum, chi2/dof {result.chi2_per_dof:.2f}"
    return save_figure(fig, ax, path, title)
