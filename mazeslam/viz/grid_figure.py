"""The grid filter's figure: the best particle's occupancy grid, the paths and the final particles."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mazeslam.data.map_io import OccupancyMap, to_image


def plot_grid_run(
    path: str | Path,
    occupancy: OccupancyMap,
    mean: np.ndarray,
    best: np.ndarray,
    particles: np.ndarray,
    title: str,
    truth: np.ndarray | None = None,
    truth_label: str = "true path",
) -> Path:
    """Draw the map ``occupancy`` (grey unknown, white free, black occupied; world frame, metres)
    with the mean path ``mean`` (R, 3), the best particle's path ``best`` (R, 3), the final
    ``particles`` (P, 3) and, when given, ``truth`` (R, 3); save to ``path``."""
    import matplotlib.pyplot as plt

    from mazeslam.viz.plots import save_figure

    fig, ax = plt.subplots(figsize=(9, 7))
    if occupancy.states.size:
        rows, columns = occupancy.states.shape
        x0, y0 = occupancy.origin[:2]
        extent = (x0, x0 + rows * occupancy.resolution, y0, y0 + columns * occupancy.resolution)
        ax.imshow(to_image(occupancy.states), cmap="gray", vmin=0, vmax=255, extent=extent, interpolation="nearest")
        ax.plot([], [], "s", color="black", label="occupied cells (best particle's map)")
    if truth is not None:
        ax.plot(truth[:, 0], truth[:, 1], color="tab:green", lw=1.2, label=truth_label)
    ax.plot(mean[:, 0], mean[:, 1], color="tab:blue", lw=1.2, label="mean path")
    ax.plot(best[:, 0], best[:, 1], color="tab:orange", lw=0.9, ls="--", label="best particle's path")
    ax.plot(particles[:, 0], particles[:, 1], ".", color="red", ms=3, label="particles at the end")
    ax.set(xlabel="x [m]", ylabel="y [m]", aspect="equal")
    return save_figure(fig, ax, path, title)
