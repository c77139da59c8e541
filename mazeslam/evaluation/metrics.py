"""Error metrics against ground truth: trajectory (ATE) and map."""

from __future__ import annotations

import numpy as np

from mazeslam.core.geometry import relative, wrap_angle


def align_se2(estimate: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """The rigid motion (x, y, theta) that best maps ``estimate`` positions onto ``truth`` ones.

    Closed-form least squares (Horn 1987 / Umeyama 1991 without scale, in 2-D): centre both point
    sets, the rotation angle is atan2 of the summed cross and dot products, the translation maps
    the rotated centroid onto the true one. Inputs (R, >=2); only x, y are used.
    """
    a, b = np.asarray(estimate, dtype=float)[:, :2], np.asarray(truth, dtype=float)[:, :2]
    a_mean, b_mean = a.mean(axis=0), b.mean(axis=0)
    a0, b0 = a - a_mean, b - b_mean
    angle = np.arctan2(np.sum(a0[:, 0] * b0[:, 1] - a0[:, 1] * b0[:, 0]), np.sum(a0 * b0))
    rotation = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    translation = b_mean - rotation @ a_mean
    return np.array([translation[0], translation[1], angle])


def apply_se2(transform: np.ndarray, poses: np.ndarray) -> np.ndarray:
    """Poses (R, 3) or points (R, 2) moved by the rigid motion ``transform`` (x, y, theta)."""
    poses = np.asarray(poses, dtype=float)
    c, s = np.cos(transform[2]), np.sin(transform[2])
    moved = poses.copy()
    moved[:, 0] = transform[0] + c * poses[:, 0] - s * poses[:, 1]
    moved[:, 1] = transform[1] + s * poses[:, 0] + c * poses[:, 1]
    if poses.shape[1] > 2:
        moved[:, 2] = wrap_angle(poses[:, 2] + transform[2])
    return moved


def absolute_trajectory_error(estimate: np.ndarray, truth: np.ndarray, align: bool = False) -> dict[str, float]:
    """Position error between two trajectories sampled at the same records.

    ``estimate`` and ``truth`` are (R, 3) or (R, 2) arrays in the same world frame (metres). With
    ``align`` the estimate is first moved by the best rigid motion (``align_se2``). Returns the
    RMSE, mean, median and max of the per-record Euclidean position errors, in metres.
    """
    estimate, truth = np.asarray(estimate, dtype=float), np.asarray(truth, dtype=float)
    if estimate.shape[0] != truth.shape[0] or estimate.shape[0] == 0:
        raise ValueError(
            f"trajectories must have the same, non-zero number of poses, got {estimate.shape[0]} and {truth.shape[0]}"
        )
    if align:
        estimate = apply_se2(align_se2(estimate, truth), estimate)
    errors = np.hypot(*(estimate[:, :2] - truth[:, :2]).T)
    return {
        "rmse": float(np.sqrt(np.mean(errors**2))),
        "mean": float(errors.mean()),
        "median": float(np.median(errors)),
        "max": float(errors.max()),
    }


def relative_pose_error(estimate: np.ndarray, truth: np.ndarray, delta: float, unit: str = "m") -> dict[str, float]:
    """Relative pose error: how wrong the estimated motion is over stretches of the true path.

    The true path is cut into consecutive stretches of at least ``delta`` metres travelled
    (``unit="m"``) or ``delta`` records (``unit="records"``), as evo's ``filter_pairs_by_path`` /
    ``filter_pairs_by_index`` do; for each stretch (i, j) the error is the estimated motion seen
    from the true one, ``(truth_i^-1 truth_j)^-1 (estimate_i^-1 estimate_j)``. Returns the RMSE,
    mean and max of its translation (m) and the RMSE of its rotation (rad), and the pair count.
    """
    estimate, truth = np.asarray(estimate, dtype=float), np.asarray(truth, dtype=float)
    if unit == "records":
        step = int(delta)
        if step < 1:
            raise ValueError(f"a record delta must be at least 1, got {delta}")
        ids = np.arange(0, len(truth), step)
    elif unit == "m":
        chosen, travelled = [0], 0.0
        for k in range(1, len(truth)):
            travelled += float(np.hypot(*(truth[k, :2] - truth[k - 1, :2])))
            if travelled >= delta:
                chosen.append(k)
                travelled = 0.0
        ids = np.array(chosen)
    else:
        raise ValueError(f"unit must be 'm' or 'records', got {unit!r}")
    if len(ids) < 2:
        return {
            "trans_rmse": float("nan"),
            "trans_mean": float("nan"),
            "trans_max": float("nan"),
            "rot_rmse": float("nan"),
            "pairs": 0,
        }
    i, j = ids[:-1], ids[1:]
    error = relative(relative(truth[i], truth[j]), relative(estimate[i], estimate[j]))
    translation = np.hypot(error[:, 0], error[:, 1])
    return {
        "trans_rmse": float(np.sqrt(np.mean(translation**2))),
        "trans_mean": float(translation.mean()),
        "trans_max": float(translation.max()),
        "rot_rmse": float(np.sqrt(np.mean(error[:, 2] ** 2))),
        "pairs": int(len(i)),
    }


def normalized_estimation_error(estimate: np.ndarray, covariances: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """NEES per record: e^T C^-1 e for the pose error e (heading wrapped) and the filter's pose
    covariance C (R, 3, 3). A consistent filter averages 3 (the pose's dimension); records whose
    covariance is singular give NaN."""
    error = np.asarray(estimate, dtype=float) - np.asarray(truth, dtype=float)
    error[:, 2] = wrap_angle(error[:, 2])
    nees = np.full(len(error), np.nan)
    regular = np.linalg.det(covariances) > 1e-30
    whitened = np.linalg.solve(covariances[regular], error[regular][..., None])[..., 0]
    nees[regular] = np.einsum("ri,ri->r", error[regular], whitened)
    return nees


def map_error(landmarks: np.ndarray, true_landmarks: np.ndarray, match_radius: float = 0.05) -> dict[str, float]:
    """How well estimated landmarks (L, 2) fit the true ones (K, 2), metres.

    One-to-one assignment minimising the summed distances (``scipy.optimize.linear_sum_assignment``);
    pairs farther apart than ``match_radius`` do not count as matches. Returns the RMSE of matched
    pairs, the number matched, precision (matched / estimated) and recall (matched / true).
    """
    landmarks = np.asarray(landmarks, dtype=float).reshape(-1, 2)
    true_landmarks = np.asarray(true_landmarks, dtype=float).reshape(-1, 2)
    if len(landmarks) == 0 or len(true_landmarks) == 0:
        return {
            "rmse": float("nan"),
            "matched": 0,
            "precision": float("nan") if len(landmarks) == 0 else 0.0,
            "recall": 0.0,
        }
    from scipy.optimize import linear_sum_assignment  # scipy.optimize: 0.1 s, loaded when first scored

    distances = np.hypot(*(landmarks[:, None, :] - true_landmarks[None]).transpose(2, 0, 1))
    rows, cols = linear_sum_assignment(distances)
    close = distances[rows, cols] <= match_radius
    matched = distances[rows, cols][close]
    return {
        "rmse": float(np.sqrt(np.mean(matched**2))) if len(matched) else float("nan"),
        "matched": int(close.sum()),
        "precision": float(close.sum() / len(landmarks)),
        "recall": float(close.sum() / len(true_landmarks)),
    }
