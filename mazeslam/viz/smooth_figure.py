"""The batch optimum's figure (``smooth.png``): its map, scan points placed by its poses, its path."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mazeslam.core.motion import dead_reckoning
from mazeslam.data.loaded_run import LoadedRun
from mazeslam.smoothing.optimum import Smoothed


def plot_smoothed(path, run: LoadedRun, smoothed: Smoothed, points: np.ndarray) -> Path:
    """The slam figure for the optimum: its map with 2-sigma ellipses, faint scan points placed by its
    poses, its path (start and end marked) beside dead reckoning; with the sidecars, the walls (drawn
    over the points), true path and true corners."""
    from mazeslam.viz.backends import file_figure
    from mazeslam.viz.plots import draw_ellipses, draw_walls, mark_end, mark_start, save_figure

    fig = file_figure(figsize=(9, 7))
    ax = fig.subplots()
    if len(points):  # faint and rasterised, as in slam.png (slam_figure.draw_slam_figure)
        ax.plot(
            *points.T, ".", color="black", markersize=0.6, alpha=0.15, label="scan points", rasterized=True, zorder=1
        )
    draw_walls(ax, run.walls, colour="tab:brown", linewidth=1.2)  # over the points: they do not hide it
    paths = {
        "dead reckoning": (dead_reckoning(run.log, run.start_pose), "0.5"),
        "batch optimum": (smoothed.poses, "tab:blue"),
    }
    if run.truth is not None:
        paths[run.truth_path_label] = (run.truth, "tab:green")
    for label, (poses, colour) in paths.items():
        ax.plot(poses[:, 0], poses[:, 1], color=colour, linewidth=1.2, label=label)
    poses = smoothed.poses
    mark_start(ax, poses, "tab:blue")
    mark_end(ax, poses, "tab:blue")
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
