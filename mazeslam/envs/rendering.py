"""Pictures of the Gymnasium environment, drawn off-screen with matplotlib on an Agg canvas of their
own: no display needed, and pyplot's backend (a window's, a notebook's) is left alone."""

from __future__ import annotations

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.patches import Circle, Rectangle

from mazeslam.core.geometry import transform_points


def draw_maze_env(env, slam: dict | None = None, size_pixels: int = 480) -> np.ndarray:
    """An RGB image (H, W, 3) of ``env`` (a ``MazeEnv``): visited cells shaded, walls (seen ones
    dark), the robot, its laser rays (from the sensor to each return); with ``slam``
    (``{"particles": (P, 3), "landmarks": (L, 2)}``) the filter too."""
    fig = Figure(figsize=(size_pixels / 100, size_pixels / 100), dpi=100)
    canvas = FigureCanvasAgg(fig)  # not pyplot's: no window, whatever its backend
    ax = fig.add_axes((0, 0, 1, 1))
    maze, s = env.maze, env.maze.cell_size
    for row, col in np.argwhere(env.visited):
        ax.add_patch(Rectangle((col * s, row * s), s, s, color="#dfeedd", zorder=0))
    for x1, y1, x2, y2 in env.walls.surfaces:
        ax.plot([x1, x2], [y1, y2], color="0.75", linewidth=1.5, zorder=1)
    seen = env._samples[env.seen]
    ax.plot(seen[:, 0], seen[:, 1], ".", color="0.15", markersize=2, zorder=2)
    pose = env.world.pose
    geometry = env.config.laser.geometry
    sensor = transform_points(pose, (geometry.mount_x, geometry.mount_y))
    ends = transform_points(pose, geometry.returns(env.last_scan))
    for end in ends[:: max(1, len(ends) // 60)]:
        ax.plot([sensor[0], end[0]], [sensor[1], end[1]], color="tab:red", linewidth=0.4, alpha=0.5, zorder=3)
    if slam is not None:
        particles = slam.get("particles")
        if particles is not None:
            ax.plot(particles[:, 0], particles[:, 1], ".", color="red", markersize=2, zorder=7)  # over the robot's disc
        landmarks = slam.get("landmarks")
        if landmarks is not None and len(landmarks):
            ax.plot(landmarks[:, 0], landmarks[:, 1], "+", color="tab:purple", markersize=8, zorder=4)
    radius = env.config.robot.body_radius
    ax.add_patch(Circle(pose[:2], radius, color="tab:blue", zorder=5))
    nose = transform_points(pose, (radius, 0.0))
    ax.plot([pose[0], nose[0]], [pose[1], nose[1]], color="white", linewidth=2, zorder=6)
    margin = 0.02
    ax.set_xlim(-margin, maze.cols * s + margin)
    ax.set_ylim(-margin, maze.rows * s + margin)
    ax.set_aspect("equal")
    ax.axis("off")
    canvas.draw()
    return np.asarray(canvas.buffer_rgba())[..., :3].copy()
