"""Reading CARMEN laser logs (plain or gzipped), as in the Radish repository's "corrected" logs.

Lines (whitespace separated) this reader uses::

    FLASER n r_1 .. r_n x y theta odom_x odom_y odom_theta timestamp host logger_timestamp
    ODOM x y theta tv rv accel timestamp host logger_timestamp
    PARAM name value ...

FLASER is the front laser: n ranges in metres over 180 degrees, from -90 degrees (right) to +90
degrees (left) counter-clockwise, first and last beam included; ``x y theta`` is the corrected
(reference) pose of the scan, ``odom_*`` the raw odometry pose. Every other message type (NEFF,
RLASER, SYNC, comments, ...) is counted and otherwise ignored.
"""

from __future__ import annotations

import gzip
import math
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mazeslam.beams import BeamGeometry
from mazeslam.log import LogFormatError


@dataclass
class CarmenLog:
    """Front-laser scans and odometry of a CARMEN log.

    Attributes:
        scan_times: (S,) seconds (the message timestamp).
        ranges: (S, N) metres.
        scan_poses: (S, 3) the corrected pose of each scan (x, y, theta), a reference, not truth.
        scan_odometry: (S, 3) the odometry pose stored with each scan.
        odometry_times: (K,) seconds; odometry_poses: (K, 3) ODOM poses.
        params: PARAM name -> value (text).
        ignored: message type -> count of the lines not used.
    """

    source: str
    scan_times: np.ndarray
    ranges: np.ndarray
    scan_poses: np.ndarray
    scan_odometry: np.ndarray
    odometry_times: np.ndarray
    odometry_poses: np.ndarray
    params: dict = field(default_factory=dict)
    ignored: Counter = field(default_factory=Counter)

    @property
    def n_beams(self) -> int:
        return self.ranges.shape[1]

    @property
    def max_range(self) -> float:
        """The laser's maximum range (m): the ``robot_front_laser_max`` PARAM, else the largest reading."""
        value = self.params.get("robot_front_laser_max")
        return float(value) if value is not None else float(self.ranges.max())


#: A CARMEN front laser: its beams from -90 to +90 degrees (both included), counter-clockwise.
FRONT_LASER = BeamGeometry(first_beam_angle=-math.pi / 2, direction=1, field_of_view=math.pi)


def _open_text(path: Path):
    with path.open("rb") as probe:
        gzipped = probe.read(2) == b"\x1f\x8b"
    return gzip.open(path, "rt") if gzipped else path.open()


def read_carmen(path: str | Path) -> CarmenLog:
    """Read the FLASER, ODOM and PARAM lines of a CARMEN log; errors name the file and the line."""
    path = Path(path)
    scans, odometry, params, ignored = [], [], {}, Counter()
    width = None
    with _open_text(path) as handle:
        for number, line in enumerate(handle, start=1):
            parts = line.split()
            if not parts:
                continue
            kind = parts[0]
            try:
                if kind == "FLASER":
                    n = int(parts[1])
                    if len(parts) < n + 9:
                        raise ValueError(f"FLASER with {n} ranges needs {n + 9} values at least, got {len(parts)}")
                    if width is not None and n != width:
                        raise ValueError(f"FLASER has {n} ranges, earlier scans had {width}")
                    width = n
                    values = [float(v) for v in parts[2 : n + 8]]
                    scans.append(values + [float(parts[n + 8])])
                elif kind == "ODOM":
                    odometry.append([float(v) for v in parts[1:4]] + [float(parts[7])])
                elif kind == "PARAM" and len(parts) >= 3:
                    params[parts[1]] = parts[2]
                else:
                    ignored[kind] += 1
            except (ValueError, IndexError) as error:
                raise LogFormatError(str(path), number, f"bad {kind} line: {error}") from error
    if not scans:
        raise LogFormatError(str(path), 1, "no FLASER (front laser) lines in this CARMEN log")
    table = np.array(scans)
    odometry_table = np.array(odometry).reshape(-1, 4)
    return CarmenLog(
        source=str(path),
        scan_times=table[:, -1],
        ranges=table[:, :width],
        scan_poses=table[:, width : width + 3],
        scan_odometry=table[:, width + 3 : width + 6],
        odometry_times=odometry_table[:, 3],
        odometry_poses=odometry_table[:, :3],
        params=params,
        ignored=ignored,
    )


def is_carmen(path: str | Path) -> bool:
    """Whether a file looks like a CARMEN log (a FLASER, ODOM or PARAM line among its first 200)."""
    with _open_text(Path(path)) as handle:
        for _, line in zip(range(200), handle):
            if line.split()[:1] in (["FLASER"], ["ODOM"], ["PARAM"]):
                return True
    return False
