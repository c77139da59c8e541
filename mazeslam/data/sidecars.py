"""Files written beside a log ``run.log``: ``run.truth.csv`` (true poses) and ``run.map.json`` (the world).

``run.truth.csv`` — header ``t,x,y,theta``, then one row per log record, in record order: the true
pose of the robot (wheel-axle centre) in the world frame when the record was taken; metres,
radians in (-pi, pi].

``run.map.json`` — a JSON object (schema in ``docs/formats.md``) with at least:

* ``walls``: list of ``[x1, y1, x2, y2]``, the wall surfaces the laser hits (thickness applied), m;
* ``corners``: list of ``[x, y]``, the true corners of those surfaces, m;
* ``sensor``: the beam geometry and noise (``beams``, ``max_range``, ``range_noise_std``,
  ``first_beam_angle``, ``direction``, ``field_of_view``, ``mount_x``, ``mount_y``, ...);
* and, from the simulator, ``corner_convex``, ``start_pose``, ``seed``, ``maze`` and every parameter.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np

from mazeslam.core.beams import BeamGeometry
from mazeslam.core.config import InputError, jsonable, read_text
from mazeslam.core.outputs import close_written, write_file, write_line, written

TRUTH_HEADER = "t,x,y,theta"
MAP_FORMAT = "mazeslam-map"
MAP_VERSION = 1


def sidecar_path(log_path: str | Path, kind: str) -> Path:
    """``run.log`` -> ``run.<kind>``, e.g. ``sidecar_path('runs/a.log', 'truth.csv')`` is ``runs/a.truth.csv``."""
    log_path = Path(log_path)
    return log_path.with_name(f"{log_path.stem}.{kind}")


def truth_path(log_path: str | Path) -> Path:
    return sidecar_path(log_path, "truth.csv")


def map_path(log_path: str | Path) -> Path:
    return sidecar_path(log_path, "map.json")


def write_truth(path: str | Path, times: np.ndarray, poses: np.ndarray) -> None:
    """Write ``times`` (R,) seconds and ``poses`` (R, 3) ``x, y, theta`` as a truth CSV (whole or
    not at all, as every writer here: ``mazeslam.core.outputs.written``)."""
    table = np.column_stack([np.asarray(times, dtype=float), np.asarray(poses, dtype=float)])
    if table.ndim != 2 or table.shape[1] != 4:
        raise ValueError(f"truth needs times (R,) and poses (R, 3), got a table shaped {table.shape}")
    with written(path) as temporary:
        np.savetxt(temporary, table, fmt="%.6f", delimiter=",", header=TRUTH_HEADER, comments="")


class TruthWriter:
    """Writes a truth CSV row by row, flushing each, so a recording that is killed keeps every
    pose written (as ``write_truth`` would have written them). Use as a context manager."""

    def __init__(self, path: str | Path):
        self.path = Path(path)
        self._file = self.path.open("w")
        write_line(self._file, self.path, TRUTH_HEADER)

    def write(self, t: float, pose) -> None:
        x, y, theta = (float(v) for v in pose)
        write_line(self._file, self.path, f"{t:.6f},{x:.6f},{y:.6f},{theta:.6f}")

    def close(self) -> None:
        close_written(self._file, self.path)

    def __enter__(self) -> TruthWriter:
        return self

    def __exit__(self, *exc_info) -> None:
        self.close()


def read_truth(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """Read a truth CSV: ``(times (R,), poses (R, 3))``. Errors name the file and what is wrong."""
    path = Path(path)
    table = _read_table(path, TRUTH_HEADER, "truth sidecar")
    if table.shape[1] != 4 or not np.all(np.isfinite(table)):
        raise ValueError(f"{path}: every row needs 4 finite values t,x,y,theta")
    return table[:, 0], table[:, 1:]


def _read_table(path: Path, header: str, what: str) -> np.ndarray:
    """The rows of a CSV sidecar under ``header``; errors name the file (and the line)."""
    text = read_text(path, what)
    lines = text.splitlines()
    found = lines[0].strip() if lines else ""
    if found.replace(" ", "") != header:
        raise ValueError(f"{path}:1: expected the header {header!r}, got {_short(found)!r}")
    columns = header.count(",") + 1
    try:
        table = np.loadtxt(lines[1:], delimiter=",", ndmin=2) if len(lines) > 1 else np.empty((0, columns))
    except ValueError as error:
        raise ValueError(f"{path}: {_short(str(error), 200)}") from error
    if table.shape[1] != columns:
        raise ValueError(f"{path}: every row needs {columns} values {header}")
    return table


def _short(text: str, limit: int = 60) -> str:
    return text if len(text) <= limit else text[: limit - 3] + "..."


#: Header of a filter's trajectory: the pose and its covariance's upper triangle (m^2, m rad, rad^2).
TRAJECTORY_HEADER = "t,x,y,theta,cov_xx,cov_xy,cov_xtheta,cov_yy,cov_ytheta,cov_thetatheta"
_UPPER = np.triu_indices(3)


def write_trajectory(path: str | Path, times: np.ndarray, poses: np.ndarray, covariances: np.ndarray) -> None:
    """Write an estimated trajectory: ``times`` (R,) s, ``poses`` (R, 3) and their covariances
    (R, 3, 3), one row per record under ``TRAJECTORY_HEADER``."""
    upper = np.asarray(covariances, dtype=float)[:, _UPPER[0], _UPPER[1]]
    table = np.column_stack([np.asarray(times, dtype=float), np.asarray(poses, dtype=float), upper])
    with written(path) as temporary:
        np.savetxt(
            temporary, table, fmt=["%.6f"] * 4 + ["%.9g"] * 6, delimiter=",", header=TRAJECTORY_HEADER, comments=""
        )


def read_trajectory(path: str | Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Read a trajectory written by ``write_trajectory``: times (R,), poses (R, 3), covariances (R, 3, 3)."""
    path = Path(path)
    table = _read_table(path, TRAJECTORY_HEADER, "trajectory")
    covariances = np.zeros((len(table), 3, 3))
    covariances[:, _UPPER[0], _UPPER[1]] = table[:, 4:]
    covariances[:, _UPPER[1], _UPPER[0]] = table[:, 4:]
    return table[:, 0], table[:, 1:4], covariances


def write_tum(path: str | Path, times: np.ndarray, poses: np.ndarray) -> None:
    """Write poses (R, 3) as a TUM trajectory: ``t x y z qx qy qz qw`` per line, z = 0, the heading
    as a rotation about z (for evo and other trajectory tools)."""
    poses = np.asarray(poses, dtype=float)
    half = 0.5 * poses[:, 2]
    zeros = np.zeros(len(poses))
    table = np.column_stack([times, poses[:, 0], poses[:, 1], zeros, zeros, zeros, np.sin(half), np.cos(half)])
    with written(path) as temporary:
        np.savetxt(temporary, table, fmt="%.9f")


def write_map(path: str | Path, walls, corners, sensor: dict, **extra) -> None:
    """Write a map sidecar; ``extra`` keys (JSON-serialisable) are stored beside the required ones."""
    document = {
        "format": MAP_FORMAT,
        "version": MAP_VERSION,
        "walls": np.round(np.asarray(walls, dtype=float), 6).tolist(),
        "corners": np.round(np.asarray(corners, dtype=float), 6).tolist(),
        "sensor": sensor,
        **extra,
    }
    text = json.dumps(jsonable(document), indent=1, allow_nan=False)
    # One line per innermost list (a wall, a corner) keeps the file short and readable.
    text = re.sub(r"\[([^\[\]{}\"]*)\]", lambda m: "[" + " ".join(m.group(1).split()) + "]", text)
    write_file(path, text + "\n")


def read_map(path: str | Path) -> dict:
    """Read a map sidecar; ``walls`` (W, 4) and ``corners`` (K, 2) come back as float arrays."""
    path = Path(path)
    try:
        document = json.loads(read_text(path, "map sidecar"))
    except json.JSONDecodeError as error:
        raise ValueError(f"{path}: not valid JSON: {error}") from error
    if not isinstance(document, dict):
        raise ValueError(f"{path}: a map sidecar is a JSON object, got {type(document).__name__}")
    missing = [key for key in ("walls", "corners", "sensor") if key not in document]
    if missing:
        raise ValueError(f"{path}: the map sidecar lacks {', '.join(missing)}")
    for key, width in (("walls", 4), ("corners", 2)):
        try:
            document[key] = np.asarray(document[key], dtype=float).reshape(-1, width)
        except (TypeError, ValueError):
            raise ValueError(f"{path}: {key} must be a list of [{width} numbers]") from None
        if not np.all(np.isfinite(document[key])):
            raise ValueError(f"{path}: {key} holds a number that is not finite")
    sensor = document["sensor"]
    if sensor is not None and not isinstance(sensor, dict):
        raise ValueError(f"{path}: sensor must be an object (or null)")
    max_range = (sensor or {}).get("max_range")
    if max_range is not None and (
        isinstance(max_range, bool) or not isinstance(max_range, (int, float)) or not 0 <= max_range < math.inf
    ):
        raise InputError(f"{path}: sensor max_range must be a number >= 0 (m), got {max_range!r}")
    return document


def beam_geometry(sensor: dict) -> BeamGeometry:
    """The ``BeamGeometry`` recorded in a map sidecar's ``sensor`` section."""
    from mazeslam.core.config import ConfigError, from_mapping

    keys = ("first_beam_angle", "direction", "field_of_view", "mount_x", "mount_y")
    try:
        given = {key: sensor[key] for key in keys if sensor.get(key) is not None}
        return from_mapping(BeamGeometry, given, "map sidecar [sensor]")
    except ConfigError as error:
        raise ValueError(str(error)) from error
