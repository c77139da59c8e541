"""A run's map for other tools: an occupancy grid in the ROS map_server convention and the landmarks as CSV.

The grid is built from the log's scans placed along an estimated path (the filter's mean path):
every beam marks the cells it crosses free and the cell it ends in occupied, in log-odds, as an
occupancy-grid mapper with known poses does. Returns beyond ``max_range`` (untrusted) only clear the
cells up to ``max_range``; no return (0) marks nothing. The cell states are written by
``mazeslam.data.map_io.write_map`` (``occupancy.pgm``, ``occupancy.yaml``),
the reader and writer the grid filter uses too.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from mazeslam.core.beams import BeamGeometry
from mazeslam.core.outputs import write_file
from mazeslam.data import log
from mazeslam.data.map_io import FREE, OCCUPIED, UNKNOWN, OccupancyMap, write_map

#: Log-odds a beam adds to the cell it ends in, and to each cell it crosses (as ``grid.occupancy``).
HIT, MISS, CLAMP = 0.85, -0.4, 5.0
#: Largest image side, pixels: the resolution is coarsened until the map fits.
MOST_PIXELS = 4000


def choose_resolution(extent: float) -> float:
    """Cell size for a map spanning ``extent`` metres: 1 cm for a course maze (up to 10 m), 5 cm
    for a building, coarser only when the image would exceed ``MOST_PIXELS`` on a side."""
    resolution = 0.01 if extent <= 10.0 else 0.05
    while extent / resolution > MOST_PIXELS:
        resolution *= 2
    return resolution


def occupancy_from_scans(
    course_log: log.CourseLog,
    poses: np.ndarray,
    geometry: BeamGeometry,
    min_range: float = 0.0,
    max_range: float = math.inf,
    resolution: float | None = None,
) -> OccupancyMap:
    """The occupancy map of ``course_log``'s scans placed by ``poses`` (R, 3), one per record.

    Ranges below ``min_range`` (and 0, no return) are left out; a range above ``max_range`` clears
    the cells up to ``max_range`` and marks none occupied. ``resolution`` (m): from the map's extent
    when None (``choose_resolution``). An empty map (no scans) has no cells."""
    scans = np.flatnonzero(course_log.is_scan)
    n_beams = course_log.width
    bearings = geometry.bearings(n_beams) if len(scans) else np.empty(0)
    directions = np.column_stack([np.cos(bearings), np.sin(bearings)])
    mount = np.array([geometry.mount_x, geometry.mount_y])
    beams = []  # per scan: sensor position (2,), beam ends (K, 2) in the world, which of them are hits (K,)
    for index in scans:
        ranges = course_log.values[index]
        valid = np.isfinite(ranges) & (ranges > max(min_range, 0.0))
        reach = np.minimum(ranges[valid], max_range)
        pose = poses[index]
        c, s = math.cos(pose[2]), math.sin(pose[2])
        rotation = np.array([[c, -s], [s, c]])
        local = mount + reach[:, None] * directions[valid]
        beams.append((pose[:2] + rotation @ mount, pose[:2] + local @ rotation.T, ranges[valid] <= max_range))
    if not beams:
        return OccupancyMap(np.zeros((0, 0), dtype=np.int8), resolution or 0.05, np.zeros(3))
    every = np.vstack([np.vstack([origin[None], ends]) for origin, ends, _ in beams])
    low, high = every.min(axis=0), every.max(axis=0)
    resolution = resolution or choose_resolution(float((high - low).max()))
    origin = np.floor(low / resolution) * resolution - 2 * resolution
    shape = tuple(np.ceil((high - origin) / resolution).astype(int) + 3)
    log_odds = np.zeros(shape[0] * shape[1])
    step = 0.8 * resolution
    for sensor, ends, hit in beams:
        if not len(ends):
            continue
        lengths = np.hypot(*(ends - sensor).T)
        counts = np.ceil(np.maximum(lengths - np.where(hit, 0.5 * resolution, 0.0), 0) / step).astype(int)
        beam = np.repeat(np.arange(len(ends)), counts)
        distance = (np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)) * step
        unit = (ends - sensor) / np.maximum(lengths, 1e-12)[:, None]
        samples = sensor + distance[:, None] * unit[beam]
        free = _cells(samples, origin, resolution, shape)
        hits = _cells(ends[hit], origin, resolution, shape)
        free = np.setdiff1d(free, hits)
        log_odds[free] += MISS
        log_odds[hits] += HIT
        np.clip(log_odds, -CLAMP, CLAMP, out=log_odds)
    log_odds = log_odds.reshape(shape)
    states = np.full(shape, UNKNOWN, dtype=np.int8)
    states[log_odds < 0] = FREE
    states[log_odds > 0] = OCCUPIED
    return OccupancyMap(states, resolution, np.r_[origin, 0.0])


def _cells(points: np.ndarray, origin: np.ndarray, resolution: float, shape: tuple) -> np.ndarray:
    """The distinct flat cell indices of ``points`` (N, 2) (all inside the map by construction)."""
    index = np.floor((points - origin) / resolution).astype(int)
    index = np.clip(index, 0, np.array(shape) - 1)
    return np.unique(index[:, 0] * shape[1] + index[:, 1])


def write_landmarks(path: str | Path, landmarks: np.ndarray, covariances: np.ndarray) -> Path:
    """``landmarks.csv``: one row per landmark, ``x,y,cov_xx,cov_xy,cov_yy`` (world frame, m and m^2)."""
    path = Path(path)
    rows = ["x,y,cov_xx,cov_xy,cov_yy"]
    rows += [
        f"{x:.6f},{y:.6f},{c[0, 0]:.9g},{c[0, 1]:.9g},{c[1, 1]:.9g}"
        for (x, y), c in zip(np.asarray(landmarks).reshape(-1, 2), np.asarray(covariances).reshape(-1, 2, 2))
    ]
    return write_file(path, "\n".join(rows) + "\n")


def export_map(
    out_dir: str | Path, occupancy: OccupancyMap | None, landmarks: np.ndarray, covariances: np.ndarray
) -> dict[str, Path]:
    """Write ``occupancy.pgm``/``.yaml`` (when there is an ``occupancy``: ``occupancy_from_scans``)
    and ``landmarks.csv`` (``landmarks`` (L, 2) m, ``covariances`` (L, 2, 2)) into ``out_dir``;
    returns their paths by name."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = {"landmarks": write_landmarks(out_dir / "landmarks.csv", landmarks, covariances)}
    if occupancy is not None:
        paths["occupancy"] = write_map(occupancy, out_dir, "occupancy")
        paths["occupancy_image"] = out_dir / "occupancy.pgm"
    return paths
