"""The grid filter's figure: the best particle's occupancy grid, the paths and the final particles."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mazeslam.data.map_io import FREE, OCCUPIED, PIXEL, UNKNOWN, OccupancyMap, to_image

#: About how many pixels the map's longer side gets in the figure (9 in at 120 dpi, less the margins).
MAX_PIXELS = 800


def darkest_of_blocks(image: np.ndarray, max_pixels: int) -> np.ndarray:
    """``image`` (H, W) grey levels shrunk by whole blocks until its longer side is at most
    ``max_pixels``, each block its darkest cell: an occupied cell (black) survives at building scale,
    where drawing every cell would leave most of them out between two pixels."""
    factor = max(1, -(-max(image.shape) // max_pixels))
    if factor == 1:
        return image
    rows, columns = (-(-side // factor) * factor for side in image.shape)
    padded = np.full((rows, columns), image.max(), dtype=image.dtype)
    padded[: image.shape[0], : image.shape[1]] = image
    return padded.reshape(rows // factor, factor, columns // factor, factor).min(axis=(1, 3))


def draw_occupancy(ax, occupancy: OccupancyMap) -> bool:
    """Draw ``occupancy`` on ``ax`` in the world frame (metres): black occupied, white free, grey
    unknown, shrunk by ``darkest_of_blocks``. False (nothing drawn) for an empty map."""
    if not occupancy.states.size:
        return False
    rows, columns = occupancy.states.shape
    x0, y0 = occupancy.origin[:2]
    extent = (x0, x0 + rows * occupancy.resolution, y0, y0 + columns * occupancy.resolution)
    image = darkest_of_blocks(to_image(occupancy.states), MAX_PIXELS)
    ax.imshow(image, cmap="gray", vmin=0, vmax=255, extent=extent, interpolation="nearest")
    return True


def plot_occupancy(path: str | Path, occupancy: OccupancyMap, title: str) -> Path:
    """The map ``occupancy`` alone (``occupancy.png`` beside its .pgm and .yaml), axes in metres and
    a legend of the three cell states; saved to ``path``."""
    from mazeslam.viz.backends import file_figure
    from mazeslam.viz.plots import save_figure

    fig = file_figure(figsize=(8, 7))
    ax = fig.subplots()
    draw_occupancy(ax, occupancy)
    for state, name in ((OCCUPIED, "occupied"), (FREE, "free"), (UNKNOWN, "unknown")):
        grey = str(PIXEL[state] / 255)
        ax.plot([], [], "s", color=grey, markeredgecolor="black", label=f"{name} cell")
    ax.set(xlabel="x [m]", ylabel="y [m]", aspect="equal")
    return save_figure(fig, ax, path, f"{title}\noccupancy grid, {occupancy.resolution * 100:g} cm cells")


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
    from mazeslam.viz.backends import file_figure
    from mazeslam.viz.plots import save_figure

    fig = file_figure(figsize=(9, 7))
    ax = fig.subplots()
    if draw_occupancy(ax, occupancy):
        ax.plot([], [], "s", color="black", label="occupied cells (best particle's map)")
    if truth is not None:
        ax.plot(truth[:, 0], truth[:, 1], color="tab:green", lw=1.2, label=truth_label)
    ax.plot(mean[:, 0], mean[:, 1], color="tab:blue", lw=1.2, label="mean path")
    ax.plot(best[:, 0], best[:, 1], color="tab:orange", lw=0.9, ls="--", label="best particle's path")
    ax.plot(particles[:, 0], particles[:, 1], ".", color="red", ms=3, label="particles at the end")
    ax.set(xlabel="x [m]", ylabel="y [m]", aspect="equal")
    return save_figure(fig, ax, path, title)
