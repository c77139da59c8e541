"""Reading CARMEN laser logs (plain or gzipped), as in the Radish repository's "corrected" logs.

Lines (whitespace separated) this reader uses::

    FLASER n r_1 .. r_n x y theta odom_x odom_y odom_theta timestamp host logger_timestamp
    ROBOTLASER1 laser_type start_angle field_of_view angular_resolution maximum_range accuracy
        remission_mode n r_1 .. r_n num_remissions [remissions] laser_x laser_y laser_theta
        robot_x robot_y robot_theta tv rv forward_safety_dist side_safety_dist turn_axis
        timestamp host logger_timestamp
    ODOM x y theta tv rv accel timestamp host logger_timestamp
    PARAM name value ...

FLASER is the front laser: n ranges in metres from -90 degrees (right) counter-clockwise, one
degree apart for 180/181 beams, half a degree for 360/361 (``front_laser``); ``x y theta`` is the corrected
(reference) pose of the scan, ``odom_*`` the raw odometry pose. ROBOTLASER1, the newer CARMEN
format, says its beams itself (first beam at ``start_angle``, ``angular_resolution`` apart, rad)
and its range limit; the laser's pose is the scan's reference pose, as FLASER's. A log with FLASER
lines is read from them (a ROBOTLASER1 line beside them repeats the scan); one without, from its
ROBOTLASER1 lines. Every other message type (NEFF, RLASER, SYNC, comments, ...) is counted and
otherwise ignored.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mazeslam.core.beams import BeamGeometry
from mazeslam.core.config import read_text
from mazeslam.core.limits import MAX_BEAMS
from mazeslam.core.outputs import staged_file
from mazeslam.data.log import BYTE_ORDER_MARK, MAX_TIME, MAX_VALUE, LogFormatError


@dataclass
class CarmenLog:
    """Front-laser scans and odometry of a CARMEN log.

    Attributes:
        scan_times: (S,) seconds (the message timestamp).
        ranges: (S, N) metres.
        scan_poses: (S, 3) the corrected pose of each scan (x, y, theta), a reference, not truth.
        scan_odometry: (S, 3) the odometry pose stored with each scan (FLASER; ROBOTLASER1: the
            robot's pose).
        odometry_times: (K,) seconds; odometry_poses: (K, 3) ODOM poses.
        params: PARAM name -> value (text).
        ignored: message type -> count of the lines not used.
        sequence: the scan and ODOM messages in file order, as ("scan", i) / ("odom", j).
        geometry: the beams ROBOTLASER1 lines give (None for FLASER: ``front_laser``).
        laser_max_range: ROBOTLASER1's maximum range, m (None for FLASER).
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
    sequence: list = field(default_factory=list)
    geometry: BeamGeometry | None = None
    laser_max_range: float | None = None

    @property
    def n_beams(self) -> int:
        return self.ranges.shape[1]

    @property
    def beam_geometry(self) -> BeamGeometry:
        """The scans' beams: ROBOTLASER1's own, else the front laser's (``front_laser``)."""
        return self.geometry if self.geometry is not None else front_laser(self.n_beams)

    @property
    def max_range(self) -> float:
        """The laser's maximum range (m), where a reading means no return: the first of the
        ``robot_front_laser_max`` PARAM and ROBOTLASER1's maximum range that at most
        ``STRAY_SHARE`` of the readings pass, else the largest reading (what a SICK reports for
        nothing). A stated range more readings pass is not the laser's: edmonton's PARAM says
        10 m while its scans read walls to 51 m (its laser reports nothing as 51.09-51.16 m; the
        readings below the largest stay returns, farther than any range the filters use)."""
        for value in (self.params.get("robot_front_laser_max"), self.laser_max_range):
            try:
                limit = float(value) if value is not None else math.nan
            except ValueError:
                continue
            if 0 < limit <= MAX_VALUE and np.mean(self.ranges > limit) <= STRAY_SHARE:
                return limit
        return float(self.ranges.max())


#: The share of readings that may pass a log's stated maximum range, as strays, before it is not
#: taken as the laser's (``CarmenLog.max_range``).
STRAY_SHARE = 0.001


def front_laser(n_beams: int) -> BeamGeometry:
    """A CARMEN front laser of ``n_beams``: counter-clockwise from -90 degrees, one beam a degree
    for 180 or 181 beams and half a degree for 360 or 361 (the last beam at +89, +90, +89.5 or
    +90 degrees)."""
    step = math.pi / (n_beams - n_beams % 2)
    return BeamGeometry(first_beam_angle=-math.pi / 2, direction=1, field_of_view=step * (n_beams - 1))


def _lines(path: Path) -> list[str]:
    """The lines of a plain or gzipped text file (read errors as one ``InputError`` naming it), a
    UTF-8 byte order mark before the first dropped."""
    return read_text(path, "CARMEN log").removeprefix(BYTE_ORDER_MARK).splitlines()


def _numbers(texts: list[str], what: str) -> list[float]:
    """``texts`` as finite numbers of sane magnitude (``ValueError`` naming the bad one)."""
    values = [float(v) for v in texts]
    for text, value in zip(texts, values):
        if not math.isfinite(value) or abs(value) > MAX_TIME:
            raise ValueError(f"{what} value {text!r} is not a finite number of sane size")
    return values


def _ranges(texts: list[str], what: str) -> list[float]:
    """Range readings (m) as numbers, each at least 0 and of sane size."""
    values = _numbers(texts, what)
    if min(values) < 0 or max(values) > MAX_VALUE:
        raise ValueError("a range is negative or implausibly large")
    return values


def _count(text: str) -> int:
    """A scan's beam count, 2 to ``MAX_BEAMS``."""
    n = int(text)
    if not 2 <= n <= MAX_BEAMS:
        raise ValueError(f"{n} ranges: a laser scan has 2 to {MAX_BEAMS}")
    return n


def _flaser(parts: list[str]) -> tuple[list[float], tuple]:
    """A FLASER line's ranges, pose, odometry pose and timestamp, and its beam count."""
    n = _count(parts[1])
    if len(parts) < n + 9:
        raise ValueError(f"FLASER with {n} ranges needs {n + 9} values at least, got {len(parts)}")
    values = _ranges(parts[2 : n + 2], "FLASER") + _numbers(parts[n + 2 : n + 8], "FLASER")
    return values + _numbers([parts[n + 8]], "timestamp"), (n,)


def _robotlaser(parts: list[str]) -> tuple[list[float], tuple]:
    """A ROBOTLASER1 line's ranges, laser pose, robot pose and timestamp, and its beams: count,
    first beam's angle (rad), angular resolution (rad) and maximum range (m)."""
    start, _, resolution, max_range = _numbers(parts[2:6], "ROBOTLASER1")
    n = _count(parts[8])
    remissions = int(parts[9 + n])
    poses = 10 + n + max(remissions, 0)
    if remissions < 0 or len(parts) < poses + 12:
        raise ValueError(f"ROBOTLASER1 with {n} ranges and {remissions} remissions needs {poses + 12} values")
    values = _ranges(parts[9 : 9 + n], "ROBOTLASER1") + _numbers(parts[poses : poses + 6], "ROBOTLASER1")
    return values + _numbers([parts[poses + 11]], "timestamp"), (n, start, resolution, max_range)


#: The laser messages read, and how (FLASER first: where a log has both, ROBOTLASER1 repeats it).
LASER_LINES = {"FLASER": _flaser, "ROBOTLASER1": _robotlaser}


def read_carmen(path: str | Path) -> CarmenLog:
    """Read the FLASER or ROBOTLASER1, ODOM and PARAM lines of a CARMEN log; errors name the file
    and the line (a scan whose beams differ from the first scan's among them)."""
    path = Path(path)
    scans: dict[str, list] = {kind: [] for kind in LASER_LINES}
    beams: dict[str, tuple] = {}
    odometry, params, order = [], {}, []
    ignored: Counter[str] = Counter()
    for number, line in enumerate(_lines(path), start=1):
        parts = line.split()
        if not parts:
            continue
        kind = parts[0]
        try:
            if kind in LASER_LINES:
                values, shape = LASER_LINES[kind](parts)
                first = beams.setdefault(kind, shape)
                if shape[0] != first[0] or not np.allclose(shape, first, rtol=0, atol=1e-6):
                    raise ValueError(f"its beams {shape} differ from the first {kind}'s {first} (count, angles, range)")
                scans[kind].append(values)
                order.append((kind, len(scans[kind]) - 1))
            elif kind == "ODOM":
                odometry.append(_numbers(parts[1:4], "ODOM") + _numbers([parts[7]], "timestamp"))
                order.append(("odom", len(odometry) - 1))
            elif kind == "PARAM" and len(parts) >= 3:
                params[parts[1]] = parts[2]
            else:
                ignored[kind[:40]] += 1
        except (ValueError, IndexError) as error:
            raise LogFormatError(str(path), number, f"bad {kind[:40]} line: {error}") from error
    chosen = next((kind for kind in LASER_LINES if scans[kind]), None)
    if chosen is None:
        raise LogFormatError(str(path), 1, "no FLASER or ROBOTLASER1 (laser scan) lines in this CARMEN log")
    for kind in LASER_LINES:
        if kind != chosen and scans[kind]:
            ignored[kind] += len(scans[kind])
    width = beams[chosen][0]
    table = np.array(scans[chosen])
    odometry_table = np.array(odometry).reshape(-1, 4)
    geometry, laser_max_range = None, None
    if chosen == "ROBOTLASER1":
        _, start, resolution, laser_max_range = beams[chosen]
        geometry = BeamGeometry(first_beam_angle=start, direction=1, field_of_view=resolution * (width - 1))
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
        sequence=[("scan", i) if kind == chosen else (kind, i) for kind, i in order if kind in (chosen, "odom")],
        geometry=geometry,
        laser_max_range=laser_max_range,
    )


def is_carmen(path: str | Path) -> bool:
    """Whether a file looks like a CARMEN log (a laser, ODOM or PARAM line among its first 200)."""
    for line in _lines(Path(path))[:200]:
        if line.split()[:1] in (["FLASER"], ["ROBOTLASER1"], ["ODOM"], ["PARAM"]):
            return True
    return False


def anchored_to_first_scan(start, poses: list, before: int) -> tuple:
    """The reference's poses before the first scan moved into the frame of the scans' poses.

    Before its first scan a corrected log has only raw odometry poses (the odometry's frame); the
    scans' poses are the mapping run's (another frame, and the odometry to the first scan has its
    own error). Moved rigidly so that the last of them (``poses[before - 1]``) lands on the first
    scan's pose (``poses[before]``), the ``before`` odometry records and ``start`` (3,) (the pose
    before the first record) join the scans' frame, as the odometry after each scan does, and
    dead reckoning from ``start`` reaches the first scan exactly. Returns ``(start, poses)``. With
    no odometry before the first scan the robot starts at that scan's pose; with no scan, nothing
    is moved.
    """
    from mazeslam.core.geometry import compose, relative

    if not before:
        return (poses[0] if poses else start), poses
    if before >= len(poses):
        return start, poses
    first_scan, last_raw = np.asarray(poses[before]), np.asarray(poses[before - 1])
    moved = compose(first_scan, relative(last_raw, np.asarray([start, *poses[:before]])))
    return moved[0], [*moved[1:], *poses[before:]]


def import_carmen(path: str | Path, out: str | Path) -> dict:
    """Write a CARMEN log as a course log ``out`` with a reference-pose sidecar and a sensor sidecar.

    In the "corrected" logs each scan carries the pose a mapping run estimated for it, and the ODOM
    messages after a scan start again from that pose (an ODOM with timestamp 0 re-anchors them):
    so the wheel odometry is the motion between consecutive ODOM messages *within* one scan
    interval. Each such step becomes an odometry record (distance along the step, heading
    change); each scan a scan record (ranges at or beyond the laser's maximum become 0, no
    return). The scan's own "odometry" pose is the corrected one in these logs, so it adds no
    motion. ``*.truth.csv`` holds the anchored poses (the corrected pose at each scan, plus the
    raw odometry since it; before the first scan, the raw odometry moved to end on it,
    ``anchored_to_first_scan``) - a reference from a mapping run, not independent ground truth; the
    map sidecar says so and records the front laser's beam geometry. Returns counts.
    """
    from mazeslam.data import sidecars
    from mazeslam.data.log import refuse_to_overwrite

    refuse_to_overwrite([path], [out, sidecars.truth_path(out), sidecars.map_path(out)])
    carmen = read_carmen(path)
    with staged_file(out) as staged:  # a full disk or an interrupt leaves the last import as it was
        return _write_import(carmen, path, staged)


def _write_import(carmen: CarmenLog, path: str | Path, out: Path) -> dict:
    """``import_carmen``'s writing: ``carmen`` (read from ``path``) as the course log ``out`` with its
    truth and map sidecars; returns counts."""
    from mazeslam.core.geometry import relative
    from mazeslam.data import sidecars
    from mazeslam.data.log import LogWriter

    max_range = carmen.max_range
    times, poses = [], []
    counts: Counter[str] = Counter()
    anchor = None  # the pose the current odometry stretch is measured from
    start = None  # the first anchor: where the robot is before the first record
    last_time = -math.inf

    def clock(t):
        nonlocal last_time
        if t < last_time:
            counts["timestamps moved up to keep time increasing"] += 1
            t = last_time
        last_time = t
        return t

    with LogWriter(out, carmen.n_beams) as writer:

        def step(t, pose):
            nonlocal anchor, start
            if anchor is None:
                start = pose
            else:
                motion = relative(anchor, pose)
                distance = math.copysign(math.hypot(motion[0], motion[1]), motion[0])
                writer.write_odometry(clock(t), distance, float(motion[2]))
                times.append(last_time)
                poses.append(pose)
                counts["odometry records"] += 1
                if not counts["scans"]:
                    counts["odometry records before the first scan"] += 1
            anchor = pose

        for kind, index in carmen.sequence:
            if kind == "odom":
                t = carmen.odometry_times[index]
                pose = carmen.odometry_poses[index]
                # Re-anchoring to the corrected pose (timestamp 0, or simply the scan's own pose): no motion.
                if t == 0.0 or (anchor is not None and np.allclose(pose, anchor, atol=1e-9)):
                    anchor = pose
                    counts["re-anchoring ODOM messages"] += 1
                    continue
                step(t, pose)
            else:
                t = carmen.scan_times[index]
                anchor = carmen.scan_poses[index]  # the next ODOM messages start from here
                ranges = carmen.ranges[index]
                writer.write_scan(clock(t), np.where(ranges >= max_range - 1e-6, 0.0, ranges))
                times.append(last_time)
                poses.append(carmen.scan_poses[index])
                counts["scans"] += 1
    start, poses = anchored_to_first_scan(start, poses, counts["odometry records before the first scan"])
    sidecars.write_truth(sidecars.truth_path(out), np.array(times), np.array(poses))
    sensor = {"beams": carmen.n_beams, "max_range": max_range, **carmen.beam_geometry.to_dict()}
    sidecars.write_map(
        sidecars.map_path(out),
        np.empty((0, 4)),
        np.empty((0, 2)),
        sensor,
        start_pose=np.asarray(start).tolist() if start is not None else [0.0, 0.0, 0.0],
        truth_kind="reference: poses of a grid-mapping run (gmapping), not ground truth",
        source={"carmen_log": str(path), "ignored": dict(carmen.ignored)},
    )
    counts.update({f"ignored {k} lines": v for k, v in carmen.ignored.items()})
    return dict(counts)
