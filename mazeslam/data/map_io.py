"""Occupancy maps in the ROS map_server convention: a PGM image and a YAML file beside it.

The YAML holds ``image`` (the PGM's path, relative to the YAML), ``resolution`` (m per pixel),
``origin`` ([x, y, yaw] of the image's lower-left pixel corner in the world, m and rad), ``negate``,
``occupied_thresh`` and ``free_thresh``. A pixel value ``v`` (0-255) is read as the probability
``p = (255 - v) / 255`` of being occupied (``v / 255`` when ``negate`` is 1): occupied above
``occupied_thresh``, free below ``free_thresh``, unknown between. The image's first row is the
top of the map (largest y). Maps are written trinary, as map_saver does: occupied 0, free 254,
unknown 205. A PNG of the same image is written beside them for viewing.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml

from mazeslam.core.outputs import write_file

#: Cell states, as nav_msgs/OccupancyGrid: unknown, free, occupied.
UNKNOWN, FREE, OCCUPIED = -1, 0, 100
PIXEL = {OCCUPIED: 0, FREE: 254, UNKNOWN: 205}


@dataclass
class OccupancyMap:
    """A map of cell states.

    Attributes:
        states: (X, Y) int8 ``UNKNOWN``, ``FREE`` or ``OCCUPIED``, indexed [i, j] with i along world x.
        resolution: cell size, m.
        origin: (3,) world pose (x, y, yaw) of cell [0, 0]'s lower corner, m and rad.
    """

    states: np.ndarray
    resolution: float
    origin: np.ndarray


def to_image(states: np.ndarray) -> np.ndarray:
    """The trinary PGM image (Y, X) uint8 of cell states (X, Y): row 0 is the largest y."""
    image = np.full(states.shape, PIXEL[UNKNOWN], dtype=np.uint8)
    image[states == FREE] = PIXEL[FREE]
    image[states == OCCUPIED] = PIXEL[OCCUPIED]
    return np.flipud(image.T)


def write_map(
    occupancy: OccupancyMap,
    folder: str | Path,
    name: str = "occupancy",
    occupied_thresh: float = 0.65,
    free_thresh: float = 0.196,
) -> Path:
    """Write ``name.pgm`` and ``name.yaml`` (map_server's pair) into ``folder``, each whole or not at
    all (``mazeslam.core.outputs.written``); returns the YAML's path. The map as a figure with axes
    in metres is ``mazeslam.viz.grid_figure.plot_occupancy``'s."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    image = to_image(occupancy.states)
    height, width = image.shape
    write_file(folder / f"{name}.pgm", f"P5\n{width} {height}\n255\n".encode() + image.tobytes())
    description = {
        "image": f"{name}.pgm",
        "resolution": float(occupancy.resolution),
        "origin": [float(value) for value in occupancy.origin],
        "negate": 0,
        "occupied_thresh": occupied_thresh,
        "free_thresh": free_thresh,
    }
    return write_file(folder / f"{name}.yaml", yaml.safe_dump(description, sort_keys=False))


def read_map(yaml_path: str | Path) -> OccupancyMap:
    """Read a map_server map (YAML and the image it names) back into cell states."""
    yaml_path = Path(yaml_path)
    description = yaml.safe_load(yaml_path.read_text())
    missing = {"image", "resolution", "origin", "occupied_thresh", "free_thresh"} - set(description)
    if missing:
        raise ValueError(f"{yaml_path}: missing {', '.join(sorted(missing))}")
    import cv2  # here: OpenCV is slow to load, and only reading a map back needs it

    image = cv2.imread(str(yaml_path.parent / description["image"]), cv2.IMREAD_GRAYSCALE)
    if image is None:
        raise ValueError(f"{yaml_path}: cannot read the image {description['image']!r}")
    occupied = image / 255.0 if description.get("negate", 0) else (255 - image.astype(float)) / 255.0
    states = np.full(image.shape, UNKNOWN, dtype=np.int8)
    states[occupied < description["free_thresh"]] = FREE
    states[occupied > description["occupied_thresh"]] = OCCUPIED
    return OccupancyMap(
        np.flipud(states).T.copy(), float(description["resolution"]), np.asarray(description["origin"], dtype=float)
    )
