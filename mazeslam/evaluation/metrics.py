"""Trajectory error metrics against ground truth."""

from __future__ import annotations

import numpy as np


def absolute_trajectory_error(estimate: np.ndarray, truth: np.ndarray) -> dict[str, float]:
    """Position error between two trajectories sampled at the same records, without alignment.

    ``estimate`` and ``truth`` are (R, 3) or (R, 2) arrays in the same world frame (metres). Returns
    the RMSE, mean, median and max of the per-record Euclidean position errors, in metres.
    """
    estimate, truth = np.asarray(estimate, dtype=float), np.asarray(truth, dtype=float)
    if estimate.shape[0] != truth.shape[0] or estimate.shape[0] == 0:
        raise ValueError(
            f"trajectories must have the same, non-zero number of poses, got {estimate.shape[0]} and {truth.shape[0]}"
        )
    errors = np.hypot(*(estimate[:, :2] - truth[:, :2]).T)
    return {
        "rmse": float(np.sqrt(np.mean(errors**2))),
        "mean": float(errors.mean()),
        "median": float(np.median(errors)),
        "max": float(errors.max()),
    }
