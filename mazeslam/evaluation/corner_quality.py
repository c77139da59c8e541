"""How well corner extraction finds the true corners of a simulated maze.

For every scan of a simulated log, the fixed observations (``corner``, ``wall_end``) are moved
into the world by the true pose and matched to the map's true corners:

* precision — the share of detections within ``tolerance`` of some true corner;
* recall — the share of *observable* true corners with a detection within ``tolerance``.

A true corner is observable from a pose when a perfect extractor could find it in that scan: it
is in range and in line of sight, and enough beams (``min_points`` + 1, noise-free) land on its
faces next to it — both faces for an inside corner; for a wall end one face and, just past it,
a farther surface to jump to (else the scan shows a gap, which is no landmark).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd

from mazeslam.core.geometry import compose, transform_points
from mazeslam.data import log, sidecars
from mazeslam.features.corners import CornerExtractor, CornerMode, CornerParams
from mazeslam.sim.laser import RayCaster

#: Distance (m) below which a point counts as lying on a wall face.
ON_FACE = 1e-6


def corner_faces(walls: np.ndarray, corners: np.ndarray) -> list[np.ndarray]:
    """For each corner (K, 2), the wall faces (F, 4) that end at it (two for a maze corner)."""
    faces = []
    for corner in corners:
        at_start = np.all(np.isclose(walls[:, :2], corner), axis=1)
        at_end = np.all(np.isclose(walls[:, 2:], corner), axis=1)
        faces.append(walls[at_start | at_end])
    return faces


def _on_segments(points: np.ndarray, segments: np.ndarray) -> np.ndarray:
    """(P, S) whether each point lies on each segment."""
    a, b = segments[:, :2], segments[:, 2:]
    ab = b - a
    offset = points[:, None, :] - a[None]
    s = np.clip(np.einsum("psk,sk->ps", offset, ab) / np.einsum("sk,sk->s", ab, ab), 0, 1)
    closest = a[None] + s[..., None] * ab[None]
    return np.hypot(*(points[:, None, :] - closest).transpose(2, 0, 1)) < ON_FACE


def observable_corners(
    sensor_pose, caster: RayCaster, step: float, corners, faces, convex, params: CornerParams, max_range: float
) -> np.ndarray:
    """(K,) which true corners a perfect extractor could find from ``sensor_pose`` (x, y, heading).

    ``caster`` casts the scan's beams (noise-free) against the walls, ``step`` radians apart;
    ``faces`` lists each corner's
    wall faces (``corner_faces``); ``convex`` (K,) marks wall ends.
    """
    x, y, heading = sensor_pose
    distances = caster.cast(x, y, heading)
    hit = np.isfinite(distances)
    angles = heading + caster.bearings
    points = np.column_stack([x + distances * np.cos(angles), y + distances * np.sin(angles)])[hit]
    sight_lines = RayCaster(caster_walls(caster), [0.0], np.inf)
    result = np.zeros(len(corners), dtype=bool)
    origin = np.array([x, y])
    for k, corner in enumerate(corners):
        to_corner = corner - origin
        distance = np.hypot(*to_corner)
        if distance > max_range or sight_lines.cast(x, y, np.arctan2(to_corner[1], to_corner[0]))[0] < distance - 1e-3:
            continue
        on_face = _on_segments(points, faces[k])  # (hits, faces)
        seen = on_face.sum(axis=0) >= params.lines.min_points + 1
        if len(seen) == 2 and seen.all():
            result[k] = True
        elif convex[k] and seen.any():
            face = faces[k][np.argmax(seen)]
            normal = np.array([face[1] - face[3], face[2] - face[0]]) / np.hypot(face[2] - face[0], face[3] - face[1])
            spacing = distance * step / max(abs(normal @ to_corner) / distance, 1e-9)
            result[k] = spacing <= params.max_end_spacing and _background_beyond(
                points, on_face.any(axis=1), origin, corner, distance
            )
    return result


def caster_walls(caster: RayCaster) -> np.ndarray:
    """The wall segments (W, 4) a ``RayCaster`` was built from."""
    return np.column_stack(
        [caster.start_x, caster.start_y, caster.start_x + caster.vector_x, caster.start_y + caster.vector_y]
    )


def _background_beyond(points, on_corner_faces, origin, corner, distance) -> bool:
    """Whether, at bearings just past the corner, the scan returns from a clearly farther surface."""
    bearing = np.arctan2(*(corner - origin)[::-1])
    offsets = points - origin
    angles = np.abs(np.angle(np.exp(1j * (np.arctan2(offsets[:, 1], offsets[:, 0]) - bearing))))
    near = (angles < np.radians(5)) & ~on_corner_faces
    return bool(np.any(np.hypot(*offsets[near].T) > distance + 0.05))


def evaluate_log(log_path: str | Path, params: CornerParams | None = None, tolerance: float = 0.02) -> dict:
    """Precision and recall of corner extraction on a simulated log (needs truth and map sidecars)."""
    course_log = log.read(log_path)
    _, truth = sidecars.read_truth(sidecars.truth_path(log_path))
    world = sidecars.read_map(sidecars.map_path(log_path))
    geometry = sidecars.beam_geometry(world["sensor"])
    params = replace(params or CornerParams(), mode=CornerMode.CORNERS)
    extractor = CornerExtractor(geometry, course_log.width, params)
    caster = RayCaster(world["walls"], extractor.bearings, world["sensor"]["max_range"])
    corners = world["corners"]
    convex = np.asarray(world.get("corner_convex", [True] * len(corners)), dtype=bool)
    faces = corner_faces(world["walls"], corners)
    detections = true_positives = observable_total = recalled = 0
    errors = []
    for index in np.flatnonzero(course_log.is_scan):
        features = extractor.extract(course_log.values[index])
        found = np.array([[o.x, o.y] for o in features.observations]).reshape(-1, 2)
        found_world = transform_points(truth[index], found) if len(found) else found
        gaps = np.hypot(*(found_world[:, None, :] - corners[None]).transpose(2, 0, 1))  # (D, K)
        sensor_pose = compose(truth[index], [geometry.mount_x, geometry.mount_y, 0.0])
        observable = observable_corners(
            sensor_pose, caster, extractor.step, corners, faces, convex, params, world["sensor"]["max_range"] - 0.05
        )
        detections += len(found)
        if len(found):
            nearest = gaps.min(axis=1)
            true_positives += int((nearest <= tolerance).sum())
            errors.extend(nearest[nearest <= tolerance].tolist())
            recalled += int((gaps[:, observable].min(axis=0) <= tolerance).sum()) if observable.any() else 0
        observable_total += int(observable.sum())
    return {
        "log": str(log_path),
        "scans": int(course_log.is_scan.sum()),
        "detections": detections,
        "precision": true_positives / detections if detections else float("nan"),
        "observable": observable_total,
        "recall": recalled / observable_total if observable_total else float("nan"),
        "median_error_m": float(np.median(errors)) if errors else float("nan"),
    }


def quality_table(log_paths, params: CornerParams | None = None, tolerance: float = 0.02) -> pd.DataFrame:
    """``evaluate_log`` over several logs, one row each."""
    return pd.DataFrame([evaluate_log(path, params, tolerance) for path in log_paths])
