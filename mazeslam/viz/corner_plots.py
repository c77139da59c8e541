"""The exercise's test_corner figure: range points, extracted lines in various colours, corners in green.

``ScanView`` makes the artists once and ``show`` changes only their data, so the same figure serves
one scan (``plot_scan``), an animation of every scan (``mazeslam corners --animate``) and the live
window (``mazeslam corners --live``). Everything is in the robot frame, metres: x forward, y left;
the robot is a triangle pointing along +x (its heading).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib
import numpy as np
from matplotlib.collections import LineCollection

from mazeslam.features.corners import ScanFeatures
from mazeslam.viz.backends import file_figure
from mazeslam.viz.plots import save_figure

KIND_STYLE = {
    "corner": dict(marker="o", color="tab:green", label="corner"),
    "wall_end": dict(marker="s", color="tab:green", label="wall end"),
    "occluded": dict(marker="x", color="tab:red", label="occluded end"),
    "gap": dict(marker="x", color="tab:orange", label="end at a gap"),
    "edge": dict(marker="x", color="tab:purple", label="end at the field of view"),
    "junction": dict(marker="+", color="tab:brown", label="junction"),
}
LINE_COLOURS = matplotlib.colormaps["tab10"]


class ScanView:
    """One scan's features on ``ax`` (robot frame, metres), updated in place by ``show``.

    Args:
        mount: the sensor's (x, y) on the robot; the features' points and lines are in the sensor frame.
        kinds: the observation kinds to keep a legend entry for (default: every kind).
        reach: fixed half-width of the view in metres (None: fit each scan).
    """

    def __init__(
        self,
        ax,
        mount=(0.0, 0.0),
        kinds=None,
        reach: float | None = None,
        truth: bool = False,
    ):
        self.ax, self.mount, self.reach = ax, np.asarray(mount, dtype=float), reach
        (self.points,) = ax.plot([], [], ".", color="black", markersize=2, label="range points")
        self.lines = LineCollection([], linewidths=2, label="extracted lines")
        ax.add_collection(self.lines)
        self.kinds = {}
        for kind in kinds if kinds is not None else KIND_STYLE:
            style = dict(KIND_STYLE[kind])
            (self.kinds[kind],) = ax.plot(
                [], [], linestyle="none", markersize=7, markerfacecolor="none", markeredgewidth=1.5, **style
            )
        self.truth = ax.plot([], [], "k+", markersize=9, label="true corners")[0] if truth else None
        ax.plot(0, 0, ">", color="tab:blue", markersize=10, label="robot (heading +x)")
        ax.set_aspect("equal")
        ax.set_xlabel("x forward [m]")
        ax.set_ylabel("y left [m]")
        ax.grid(True, linewidth=0.3, alpha=0.5)
        if reach is not None:
            ax.set_xlim(-reach, reach)
            ax.set_ylim(-reach, reach)

    @property
    def changing(self) -> list:
        """The artists ``show`` changes (its title included), for blitting."""
        return [
            self.points,
            self.lines,
            *self.kinds.values(),
            *([self.truth] if self.truth is not None else []),
            self.ax.title,
        ]

    def show(self, features: ScanFeatures, title: str = "", true_corners: np.ndarray | None = None) -> None:
        points = features.points + self.mount if len(features.points) else np.empty((0, 2))
        self.points.set_data(points[:, 0], points[:, 1])
        self.lines.set_segments([np.array([s.start, s.end]) + self.mount for s in features.segments])
        self.lines.set_colors([LINE_COLOURS(i % 10) for i in range(len(features.segments))])
        by_kind: dict[str, list] = {kind: [] for kind in self.kinds}
        for observation in features.observations:
            by_kind.setdefault(observation.kind, []).append((observation.x, observation.y))
        for kind, line in self.kinds.items():
            xy = np.array(by_kind[kind]).reshape(-1, 2)
            line.set_data(xy[:, 0], xy[:, 1])
        if self.truth is not None:
            xy = np.empty((0, 2)) if true_corners is None else np.asarray(true_corners).reshape(-1, 2)
            self.truth.set_data(xy[:, 0], xy[:, 1])
        if self.reach is None:
            shown = [points, np.zeros((1, 2))] + ([xy] if self.truth is not None and len(xy) else [])
            low, high = np.vstack(shown).min(axis=0), np.vstack(shown).max(axis=0)
            pad = 0.05 * max(float((high - low).max()), 0.05)
            self.ax.set_xlim(low[0] - pad, high[0] + pad)
            self.ax.set_ylim(low[1] - pad, high[1] + pad)
        if title:
            self.ax.set_title(title, fontsize=9)


def draw_scan(ax, features: ScanFeatures, mount=(0.0, 0.0), true_corners: np.ndarray | None = None) -> ScanView:
    """Draw one scan's features on ``ax`` in the robot frame (metres), with a legend entry for each
    observation kind the scan has."""
    view = ScanView(
        ax,
        mount,
        kinds=[kind for kind in KIND_STYLE if any(o.kind == kind for o in features.observations)],
        truth=true_corners is not None and len(true_corners) > 0,
    )
    view.show(features, true_corners=true_corners)
    return view


def plot_scan(
    path: str | Path, features: ScanFeatures, mount=(0.0, 0.0), title: str = "", true_corners: np.ndarray | None = None
) -> Path:
    """Save the figure of one scan (robot frame) to ``path``."""
    fig = file_figure(figsize=(7.5, 7.5))
    ax = fig.subplots()
    draw_scan(ax, features, mount, true_corners)
    return save_figure(fig, ax, path, title)
