"""``slam --animate`` under the grid filter: the best particle's map growing, scan by scan.

While the filter runs, ``GridSnapshot``s keep what a frame needs (``snapshot``): the best
particle's cell states, shrunk to at most ``MAX_CELLS`` on the longer side (a block is occupied if
any of its cells is, else free if any is, else unknown, so one-cell walls stay visible), and the
particles. ``animate_grid`` draws them (MP4 when ffmpeg is available, GIF otherwise) with the mean
path so far and the reference or true path so far.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, cast

import numpy as np

from mazeslam.grid.map_io import FREE, OCCUPIED, UNKNOWN, OccupancyMap, grid_states, to_image
from mazeslam.grid.occupancy import TiledGrid

if TYPE_CHECKING:
    from mazeslam.evaluation.slam_view import SlamView

#: The longer side of a snapshot's map, cells (a 100 m building at 0.05 m is shrunk 5 times).
MAX_CELLS = 400


@dataclass(frozen=True)
class GridSnapshot:
    """One frame: the scan's index, the best particle's map (shrunk) and the particles (P, 3)."""

    index: int
    occupancy: OccupancyMap
    particles: np.ndarray


def shrink(occupancy: OccupancyMap, max_cells: int = MAX_CELLS) -> OccupancyMap:
    """``occupancy`` shrunk by a whole factor to at most ``max_cells`` cells on its longer side
    (occupied if any cell of a block is, else free if any is, else unknown)."""
    states = occupancy.states
    factor = max(1, int(np.ceil(max(states.shape, default=0) / max_cells)))
    if factor == 1:
        return occupancy
    rows, columns = -(-states.shape[0] // factor), -(-states.shape[1] // factor)
    padded = np.full((rows * factor, columns * factor), UNKNOWN, dtype=np.int8)
    padded[: states.shape[0], : states.shape[1]] = states
    blocks = padded.reshape(rows, factor, columns, factor)
    shrunk = np.full((rows, columns), UNKNOWN, dtype=np.int8)
    shrunk[(blocks == FREE).any(axis=(1, 3))] = FREE
    shrunk[(blocks == OCCUPIED).any(axis=(1, 3))] = OCCUPIED
    return OccupancyMap(shrunk, occupancy.resolution * factor, occupancy.origin)


def snapshot(index: int, grid: TiledGrid, particles: np.ndarray) -> GridSnapshot:
    """A frame of scan ``index``: ``grid`` (the best particle's map) shrunk, a copy of ``particles``."""
    return GridSnapshot(index, shrink(grid_states(grid)), np.array(particles, dtype=float))


def animate_grid(
    path: str | Path,
    snapshots: list[GridSnapshot],
    mean_poses: np.ndarray,
    title: str,
    truth: np.ndarray | None = None,
    truth_label: str = "true path",
    frames_per_second: int = 10,
    progress: bool = False,
    video: bool | None = None,
) -> Path:
    """Draw ``snapshots`` with the mean path ``mean_poses`` (S, 3) and ``truth`` (S, 3) at the
    scans up to each frame's scan (world frame, m) into ``path`` (.mp4 with ffmpeg, else .gif);
    returns the path written."""
    import matplotlib.pyplot as plt

    from mazeslam.evaluation.slam_view import save_animation

    if not snapshots:
        raise ValueError("no snapshots to animate: the run kept none (snapshot_every = 0?)")
    last = snapshots[-1].occupancy
    points = [mean_poses[:, :2], last.origin[None, :2] + np.array([[0, 0], last.states.shape]) * last.resolution]
    if truth is not None:
        points.append(truth[:, :2])
    low, high = np.min([p.min(axis=0) for p in points], axis=0), np.max([p.max(axis=0) for p in points], axis=0)
    figure, ax = plt.subplots(figsize=(8.5, 6.5), layout="constrained")
    image = ax.imshow(np.zeros((1, 1)), cmap="gray", vmin=0, vmax=255, interpolation="nearest", extent=(0, 1, 0, 1))
    truth_line = ax.plot([], [], color="tab:green", lw=1.0, label=truth_label)[0] if truth is not None else None
    path_line = ax.plot([], [], color="tab:blue", lw=1.2, label="mean path")[0]
    cloud = ax.plot([], [], ".", color="red", ms=3, label="particles")[0]
    ax.plot([], [], "s", color="black", label="occupied cells (best particle's map)")
    ax.set(xlim=(low[0] - 1, high[0] + 1), ylim=(low[1] - 1, high[1] + 1), xlabel="x [m]", ylabel="y [m]")
    ax.set_aspect("equal")
    ax.legend(loc="upper right", fontsize=8)

    class View:
        def __init__(self):
            self.figure = figure

        def show(self, frame: GridSnapshot):
            occupancy = frame.occupancy
            rows, columns = occupancy.states.shape
            x0, y0 = occupancy.origin[:2]
            image.set_data(to_image(occupancy.states) if occupancy.states.size else np.full((1, 1), 205))
            image.set_extent((x0, x0 + rows * occupancy.resolution, y0, y0 + columns * occupancy.resolution))
            path_line.set_data(mean_poses[: frame.index + 1, 0], mean_poses[: frame.index + 1, 1])
            if truth_line is not None and truth is not None:
                truth_line.set_data(truth[: frame.index + 1, 0], truth[: frame.index + 1, 1])
            cloud.set_data(frame.particles[:, 0], frame.particles[:, 1])
            ax.set_title(f"{title}: scan {frame.index + 1} of {len(mean_poses)}", fontsize=10)
            return [image, path_line, cloud]

    view = cast("SlamView", View())  # save_animation needs only a figure and show(*frame)
    return save_animation(view, [(frame,) for frame in snapshots], path, frames_per_second, progress, video)
