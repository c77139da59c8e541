"""Each log's grid map (results/<log>_seed0/occupancy.png) beside the log's own picture
(shared/data/carmen/<log>-corrected.png), both scaled to 700 pixels: results/<log>_compare.png.

Run after run.py: ``python experiments/carmen_grid/figures.py``.
"""

from __future__ import annotations

import cv2
import numpy as np
from run import CARMEN, LOGS, RESULTS

SIZE = 700


def scaled(image: np.ndarray) -> np.ndarray:
    """``image`` (grey) scaled so that its longer side is ``SIZE`` pixels."""
    factor = SIZE / max(image.shape)
    return cv2.resize(image, None, fx=factor, fy=factor, interpolation=cv2.INTER_AREA)


def side_by_side(left: np.ndarray, right: np.ndarray) -> np.ndarray:
    """Two grey images next to each other on a grey background, 10 pixels apart."""
    height = max(left.shape[0], right.shape[0])
    pad = [np.pad(image, ((0, height - image.shape[0]), (0, 10)), constant_values=128) for image in (left, right)]
    return np.hstack(pad)


def main() -> None:
    for name in LOGS:
        ours = RESULTS / f"{name}_seed0" / "occupancy.png"
        if ours.exists():
            figure = side_by_side(
                scaled(cv2.imread(str(ours), cv2.IMREAD_GRAYSCALE)),
                scaled(cv2.imread(str(CARMEN / f"{name}-corrected.png"), cv2.IMREAD_GRAYSCALE)),
            )
            cv2.imwrite(str(RESULTS / f"{name}_compare.png"), figure)


if __name__ == "__main__":
    main()
