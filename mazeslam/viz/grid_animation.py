"""``slam --animate`` under the grid filter: the best particle's map growing, scan by scan.

``animate_grid`` draws the frames the filter kept (``mazeslam.gridslam.snapshots.GridSnapshot``)
with the mean path so far and the reference or true path so far (MP4 when ffmpeg is available,
GIF otherwise).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, cast

import numpy as np

from mazeslam.data.map_io import OccupancyMap, to_image
from mazeslam.gridslam.snapshots import GridSnapshot

if TYPE_CHECKING:
    from mazeslam.viz.slam_view import SlamView


class GridView:
    """One figure of the grid filter's state: the best particle's map (grey unknown, white free,
    black occupied), the mean path so far, the true or reference path so far and the particles;
    world frame, metres. ``show`` draws a frame (``save_animation`` and the live view call it).

    Args:
        low, high: (2,) the corners of the area shown, m.
        title: the figure's title, to which ``show`` adds the scan.
        truth_label: the legend's name of the true path ("reference path" for a log's own poses).
        figure: the figure to draw on (a window's, pyplot's); default: one for a file (``file_figure``).
    """

    def __init__(self, low: np.ndarray, high: np.ndarray, title: str, truth_label: str = "true path", figure=None):
        from mazeslam.viz.backends import file_figure

        self.figure = figure if figure is not None else file_figure(figsize=(8.5, 6.5))
        self.figure.set_layout_engine("constrained")
        self.ax = self.figure.subplots()
        ax, self.title = self.ax, title
        self.image = ax.imshow(
            np.zeros((1, 1)), cmap="gray", vmin=0, vmax=255, interpolation="nearest", extent=(0, 1, 0, 1)
        )
        self.truth_line = ax.plot([], [], color="tab:green", lw=1.0, label=truth_label)[0]
        self.path_line = ax.plot([], [], color="tab:blue", lw=1.2, label="mean path")[0]
        self.cloud = ax.plot([], [], ".", color="red", ms=3, label="particles")[0]
        ax.plot([], [], "s", color="black", label="occupied cells (best particle's map)")
        ax.set(xlabel="x [m]", ylabel="y [m]")
        ax.set_aspect("equal")
        self.frame_area(low, high)
        ax.legend(loc="upper right", fontsize=8)

    def frame_area(self, low: np.ndarray, high: np.ndarray) -> None:
        """Show the area from ``low`` to ``high`` (m), with a metre around it."""
        self.ax.set(xlim=(low[0] - 1, high[0] + 1), ylim=(low[1] - 1, high[1] + 1))

    def show(self, frame: GridSnapshot, path: np.ndarray, truth: np.ndarray | None, scans: int) -> list:
        """Draw ``frame`` with the mean ``path`` (K, >=2) and ``truth`` (K, >=2) up to its scan, of
        ``scans`` in the log; returns the artists changed."""
        occupancy = frame.occupancy
        rows, columns = occupancy.states.shape
        x0, y0 = occupancy.origin[:2]
        self.image.set_data(to_image(occupancy.states) if occupancy.states.size else np.full((1, 1), 205))
        self.image.set_extent((x0, x0 + rows * occupancy.resolution, y0, y0 + columns * occupancy.resolution))
        self.path_line.set_data(path[:, 0], path[:, 1])
        if truth is not None:
            self.truth_line.set_data(truth[:, 0], truth[:, 1])
        self.cloud.set_data(frame.particles[:, 0], frame.particles[:, 1])
        self.ax.set_title(f"{self.title}: scan {frame.index + 1} of {scans}", fontsize=10)
        return [self.image, self.path_line, self.cloud]


def occupancy_corners(occupancy: OccupancyMap) -> np.ndarray:
    """(2, 2) the lower-left and upper-right corners of ``occupancy``'s cells, m."""
    return occupancy.origin[None, :2] + np.array([[0, 0], occupancy.states.shape]) * occupancy.resolution


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
    from mazeslam.viz.slam_view import save_animation

    if not snapshots:
        raise ValueError("no snapshots to animate: the run kept none (snapshot_every = 0?)")
    points = [mean_poses[:, :2], occupancy_corners(snapshots[-1].occupancy)]
    if truth is not None:
        points.append(truth[:, :2])
    low, high = np.min([p.min(axis=0) for p in points], axis=0), np.max([p.max(axis=0) for p in points], axis=0)
    grid_view = GridView(low, high, title, truth_label)

    class View:  # save_animation needs only a figure and show(*frame)
        figure = grid_view.figure

        def show(self, frame: GridSnapshot):
            until = frame.index + 1
            return grid_view.show(
                frame, mean_poses[:until], truth[:until] if truth is not None else None, len(mean_poses)
            )

    view = cast("SlamView", View())
    return save_animation(view, [(frame,) for frame in snapshots], path, frames_per_second, progress, video)
