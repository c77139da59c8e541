"""Known association: each observation named by a known landmark, for ``association = "known"``
and the batch optimum. The names come from the truth (a simulated log's corners seen from its true
poses) or from a finished run (its map seen from its path)."""

from __future__ import annotations

import numpy as np

from mazeslam.core.geometry import polar_to_cartesian, transform_points
from mazeslam.data.loaded_run import LoadedRun
from mazeslam.fastslam.association import nearest_within


def truth_identities(run: LoadedRun, radius: float):
    """For known association on a simulated log: name each observation by the true corner (map
    sidecar) within ``radius`` metres of where the true pose (truth sidecar) puts it; -1 if none.
    A diagnosis tool: it tells association errors apart from everything else."""
    if run.truth is None or run.world is None:
        raise ValueError(f"{run.path}: known association on scans needs the truth and map sidecars to name the corners")
    return identities_along(run.truth, run.true_corners, radius)


def identities_along(poses: np.ndarray, landmarks: np.ndarray, radius: float):
    """``identify(record_index, observations (K, 2)) -> ids (K,)``: each observation named by the
    landmark (L, 2) nearest to where the pose of its record (``poses`` (R, 3)) puts it, within
    ``radius`` metres; -1 if none (``association.nearest_within``)."""

    def identify(record_index: int, observations: np.ndarray) -> np.ndarray:
        world = transform_points(poses[record_index], polar_to_cartesian(observations[:, 0], observations[:, 1]))
        return nearest_within(world, landmarks, radius)

    return identify
