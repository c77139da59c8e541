"""Each log's grid map (results/<log>_seed0/occupancy.yaml and the .pgm it names) beside the log's own
picture (shared/data/carmen/<log>-corrected.png): results/<log>_compare.png.

Run after run.py: ``python -m experiments.carmen_grid.figures``. Ours is drawn in the filter's frame
(metres, from the map's resolution and origin), so rotated by the start heading; the log's picture
is in its own pixels (it comes without a scale).
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import yaml  # noqa: E402
from matplotlib.patches import Patch  # noqa: E402

from experiments.carmen_grid.run import CARMEN, LOGS, RESULTS  # noqa: E402
from mazeslam.data.map_io import read_map, to_image  # noqa: E402

PIXELS = 600  # the longer side of each panel's image: larger maps are shrunk to it


def shrunk(image: np.ndarray) -> tuple[np.ndarray, int]:
    """A grey ``image`` shrunk by a whole factor to at most ``PIXELS`` on its longer side, each new
    pixel the darkest of its block (so one-cell walls stay visible); the image and the factor."""
    grey = image[..., 0] if image.ndim == 3 else image
    factor = max(1, int(np.ceil(max(grey.shape) / PIXELS)))
    rows, cols = (-grey.shape[0]) % factor, (-grey.shape[1]) % factor
    padded = np.pad(grey, ((0, rows), (0, cols)), mode="edge")
    blocks = padded.reshape(padded.shape[0] // factor, factor, padded.shape[1] // factor, factor)
    return blocks.min(axis=(1, 3)), factor


def compare(name: str) -> None:
    folder = RESULTS / f"{name}_seed0"
    ours, factor = shrunk(to_image(read_map(folder / "occupancy.yaml").states) / 255.0)
    meta = yaml.safe_load((folder / "occupancy.yaml").read_text())
    resolution, (x0, y0, _) = meta["resolution"], meta["origin"]
    height, width = ours.shape[0] * factor, ours.shape[1] * factor
    fig, (left, right) = plt.subplots(1, 2, figsize=(12, 6), layout="constrained")
    left.imshow(
        ours,
        cmap="gray",
        vmin=0,
        vmax=1,
        interpolation="nearest",
        extent=(x0, x0 + width * resolution, y0, y0 + height * resolution),
    )
    left.set_xlabel("x [m]")
    left.set_ylabel("y [m]")
    left.set_title(f"grid FastSLAM map, seed 0 ({resolution:g} m cells, filter frame)", fontsize=10)
    picture, shrink = shrunk(plt.imread(CARMEN / f"{name}-corrected.png"))
    right.imshow(
        picture,
        cmap="gray",
        interpolation="nearest",
        extent=(0, picture.shape[1] * shrink, picture.shape[0] * shrink, 0),
    )
    right.set_xlabel("x [pixels]")
    right.set_ylabel("y [pixels]")
    right.set_title("the map picture that comes with the log (its own pixels)", fontsize=10)
    legend = [
        Patch(facecolor="black", label="occupied"),
        Patch(facecolor="white", edgecolor="0.5", label="free"),
        Patch(facecolor=(0.8, 0.8, 0.8), label="unknown"),
    ]
    fig.legend(handles=legend, loc="outside lower center", ncol=3, fontsize=9)
    fig.suptitle(f"{name}: our occupancy grid beside the log's reference map", fontsize=11)
    fig.savefig(RESULTS / f"{name}_compare.png", dpi=110)
    plt.close(fig)


def main() -> None:
    for name in LOGS:
        if (RESULTS / f"{name}_seed0" / "occupancy.yaml").exists():
            compare(name)


if __name__ == "__main__":
    main()
