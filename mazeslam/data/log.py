"""The course log format (Annex B of the exercise): reading with validation, and writing.

One record a line, values separated by whitespace or commas::

    timestamp 0 dX dTheta -1 -1 ... -1      odometry: metres travelled, radians turned since the
                                            previous odometry record; padded with -1 to the width
    timestamp 1 r_0 r_1 ... r_{N-1}         scan: N ranges in metres, 0 = no return
    timestamp 2 id range bearing -1 ... -1  landmark observation (mazeslam's extension, not in the
                                            exercise): a point landmark with a known identity
                                            (an integer >= 0; -1 if unknown) seen at range (m) and
                                            bearing (rad) in the robot frame

Every line of a log has the same number of values (N + 2, and at least 5 in a log with landmark
observations). A log holds scans or landmark observations, not both: no filter, smoother or
calibration weighs the two together (a scan's corners carry their own covariance, a landmark record
none; known association names a scan's corners by the truth's map, a landmark record by its own id),
so a record of the other kind is a bad line. Blank lines and lines starting with
``#`` or ``%`` are comments; a UTF-8 byte order mark before the first line is dropped (editors on
Windows write one). Timestamps (seconds) never decrease. mazeslam writes values separated
by single spaces with 6 decimals, like the exercise's logger, so a log written and read back gives
the same numbers to 1e-6.

Which bearing each range belongs to is not in the log: see ``mazeslam.core.beams`` and the sidecar.
"""

from __future__ import annotations

import dataclasses
import io
import math
import os
from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import NamedTuple

import numpy as np

from mazeslam.core.config import read_text
from mazeslam.core.outputs import close_written, write_line

ODOMETRY = 0
SCAN = 1
LANDMARK = 2
PADDING = -1.0
DECIMALS = 6
_COMMENT_PREFIXES = ("#", "%")
#: Largest magnitude of a timestamp (s; Unix time in milliseconds stays below) and of a data value
#: (metres, radians, landmark ids): beyond them a value is a corrupted number, and sums of them
#: (odometry travel, poses) would overflow.
MAX_TIME = 1e13
MAX_VALUE = 1e9
#: The UTF-8 byte order mark as decoded text; dropped before a log's first line.
BYTE_ORDER_MARK = "\ufeff"


class LogFormatError(ValueError):
    """A log line that breaks the format; the message names the file, the line and the reason."""

    def __init__(self, source: str, line: int, reason: str):
        super().__init__(f"{source}:{line}: {reason}")
        self.source, self.line, self.reason = source, line, reason


@dataclass(frozen=True)
class SkippedLine:
    """A line that lenient reading left out, and why."""

    line: int
    reason: str


class OdometryRecord(NamedTuple):
    # Record number in the log, from 0. The field shadows tuple.index (a method) on purpose: the
    # name is the log's own, used across the package and the experiments.
    index: int  # type: ignore[assignment]
    t: float  # seconds
    distance: float  # dX, metres travelled since the previous odometry record
    turn: float  # dTheta, radians turned since the previous odometry record


class ScanRecord(NamedTuple):
    index: int  # type: ignore[assignment]  # shadows tuple.index, as in OdometryRecord
    t: float
    ranges: np.ndarray  # (N,) metres, 0 = no return


class LandmarkRecord(NamedTuple):
    index: int  # type: ignore[assignment]  # shadows tuple.index, as in OdometryRecord
    t: float
    landmark: int  # identity, -1 if unknown
    range: float  # metres, robot frame
    bearing: float  # radians, robot frame


@dataclass
class CourseLog:
    """A course log in memory.

    Attributes:
        times: (R,) timestamps, seconds.
        flags: (R,) record kinds, ``ODOMETRY`` (0) or ``SCAN`` (1).
        values: (R, W) the data columns after timestamp and flag; for odometry rows
            ``[dX, dTheta, -1, ...]``, for scan rows the W ranges.
        source: the file it was read from, for messages.
        line_numbers: (R,) the line of the file each record came from (1-based).
        skipped: lines left out by lenient reading.
    """

    times: np.ndarray
    flags: np.ndarray
    values: np.ndarray
    source: str = "<memory>"
    line_numbers: np.ndarray | None = None
    skipped: list[SkippedLine] = field(default_factory=list)

    def __len__(self) -> int:
        return len(self.times)

    @property
    def width(self) -> int:
        """Number of data columns W (the beam count when the log has scans)."""
        return self.values.shape[1]

    @property
    def n_beams(self) -> int | None:
        """Beams per scan, or None for a log without scans."""
        return self.width if np.any(self.flags == SCAN) else None

    @property
    def is_odometry(self) -> np.ndarray:
        return self.flags == ODOMETRY

    @property
    def is_scan(self) -> np.ndarray:
        return self.flags == SCAN

    @property
    def odometry(self) -> np.ndarray:
        """(K, 2) odometry increments ``[dX, dTheta]`` in record order."""
        return self.values[self.is_odometry, :2]

    @property
    def increments(self) -> np.ndarray:
        """(R, 2) ``[dX, dTheta]`` of every record: the odometry's increment, zero for scans and
        landmark observations (they move nothing)."""
        return np.where(self.is_odometry[:, None], self.values[:, :2], 0.0)

    @property
    def scans(self) -> np.ndarray:
        """(S, N) ranges of the scan records in record order, metres, 0 = no return."""
        return self.values[self.is_scan]

    @property
    def duration(self) -> float:
        return float(self.times[-1] - self.times[0]) if len(self) else 0.0

    @property
    def is_landmark(self) -> np.ndarray:
        return self.flags == LANDMARK

    @property
    def scans_only(self) -> bool:
        """The log has scans and no landmark records: what laser odometry and the smoothers take."""
        return bool(self.is_scan.any()) and not self.is_landmark.any()

    def records(self) -> Iterator[OdometryRecord | ScanRecord | LandmarkRecord]:
        """The records in order, as ``OdometryRecord``, ``ScanRecord`` or ``LandmarkRecord``."""
        for index, (t, flag, row) in enumerate(zip(self.times, self.flags, self.values)):
            if flag == ODOMETRY:
                yield OdometryRecord(index, float(t), float(row[0]), float(row[1]))
            elif flag == SCAN:
                yield ScanRecord(index, float(t), row)
            else:
                yield LandmarkRecord(index, float(t), int(row[0]), float(row[1]), float(row[2]))

    def longest_step(self, left_out=()) -> tuple[int, float]:
        """The record whose odometry travels farthest (its index) and how far (m), the records
        ``left_out`` (indices, e.g. glitches) aside; (0, 0.0) for a log without motion."""
        steps = np.abs(self.increments[:, 0])
        steps[np.asarray(left_out, dtype=int)] = 0.0
        index = int(np.argmax(steps)) if len(steps) else 0
        return index, float(steps[index]) if len(steps) else 0.0

    def line_of(self, index: int) -> str:
        """Where record ``index`` is, for messages: ``"line N"`` of its file, else ``"record N"``."""
        return f"line {self.line_numbers[index]}" if self.line_numbers is not None else f"record {index}"

    def without_motion(self, records) -> CourseLog:
        """This log with the odometry of ``records`` (indices) set to no motion."""
        values = self.values.copy()
        values[np.asarray(records, dtype=int), :2] = 0.0
        return dataclasses.replace(self, values=values)


def read(path: str | Path, strict: bool = True) -> CourseLog:
    """Read a course log file, validating every line.

    Strict reading (the default) raises ``LogFormatError`` at the first bad line. With
    ``strict=False`` bad lines are left out and listed in ``CourseLog.skipped``; the expected width
    is then the most common one.
    """
    return parse(read_text(path, "log file"), str(path), strict)


def parse(text: str, source: str = "<text>", strict: bool = True) -> CourseLog:
    """Parse the text of a course log; see ``read``.

    The numbers are converted all at once (numpy's C parser) and checked as arrays; only a log
    with a bad line is then read line by line, to name the first bad line and why (strict) or to
    leave the bad lines out (lenient)."""
    lines = text.removeprefix(BYTE_ORDER_MARK).splitlines()
    numbers = [
        number
        for number, line in enumerate(lines, start=1)
        if line.strip() and not line.lstrip().startswith(_COMMENT_PREFIXES)
    ]
    if not numbers:
        raise LogFormatError(source, 1, "the log holds no records")
    table = _valid_table([lines[number - 1] for number in numbers])
    if table is None:
        return _parse_line_by_line(
            [(number, lines[number - 1].replace(",", " ").split()) for number in numbers], source, strict
        )
    course_log = CourseLog(
        times=table[:, 0],
        flags=table[:, 1].astype(np.int8),
        values=table[:, 2:],
        source=source,
        line_numbers=np.array(numbers),
    )
    return _of_one_kind(course_log, strict)


def _of_one_kind(course_log: CourseLog, strict: bool) -> CourseLog:
    """``course_log`` if it holds scans or landmark observations but not both; else, strict, a
    ``LogFormatError`` at the first record of the fewer kind (of a tie, the kind that comes later),
    or, lenient, the log without that kind's records (listed in ``skipped``)."""
    scans, landmarks = np.flatnonzero(course_log.is_scan), np.flatnonzero(course_log.is_landmark)
    if not len(scans) or not len(landmarks):
        return course_log
    stray_is_landmark = len(landmarks) < len(scans) or (len(landmarks) == len(scans) and landmarks[0] > scans[0])
    stray = landmarks if stray_is_landmark else scans
    lines = course_log.line_numbers if course_log.line_numbers is not None else np.arange(len(course_log)) + 1
    reason = (
        f"a {'landmark observation (flag 2)' if stray_is_landmark else 'scan (flag 1)'} in a log of "
        f"{len(scans) if stray_is_landmark else len(landmarks)} "
        f"{'scans' if stray_is_landmark else 'landmark observations'} ({len(stray)} such line"
        f"{'s' if len(stray) > 1 else ''}): a log holds "
        "scans or landmark observations, not both"
    )
    if strict:
        raise LogFormatError(course_log.source, int(lines[stray[0]]), reason)
    keep = np.ones(len(course_log), dtype=bool)
    keep[stray] = False
    skipped = sorted([*course_log.skipped, *(SkippedLine(int(lines[i]), reason) for i in stray)], key=lambda s: s.line)
    return dataclasses.replace(
        course_log,
        times=course_log.times[keep],
        flags=course_log.flags[keep],
        values=course_log.values[keep],
        line_numbers=lines[keep],
        skipped=skipped,
    )


def _valid_table(lines: list[str]) -> np.ndarray | None:
    """The records ``lines`` (R) as a table (R, width), or None unless every line is a valid
    record (the conditions of ``_check_line``, checked over the whole table at once)."""
    try:
        table = np.loadtxt(io.StringIO("\n".join(lines).replace(",", " ")), comments=None, ndmin=2)
    except ValueError:  # a value that is not a number, or lines of different widths
        return None
    width = table.shape[1]
    if table.shape[0] != len(lines) or width < 3 or not np.isfinite(table).all():
        return None
    times, flags, values = table[:, 0], table[:, 1], table[:, 2:]
    odometry, scan, landmark = flags == ODOMETRY, flags == SCAN, flags == LANDMARK
    valid = (
        np.abs(times).max() <= MAX_TIME
        and np.abs(values).max() <= MAX_VALUE
        and not np.any(np.diff(times) < 0)
        and (odometry | scan | landmark).all()
        and not (odometry.any() and (width < 4 or np.any(table[odometry, 4:] != PADDING)))
        and not np.any(values[scan] < 0)
        and not (landmark.any() and (width < 5 or not _valid_landmarks(table[landmark])))
    )
    return table if valid else None


def _valid_landmarks(rows: np.ndarray) -> bool:
    """Landmark records (n, width >= 5): integer ids >= -1, positive ranges, padded with -1."""
    ids = rows[:, 2]
    return bool(
        np.all(ids == np.round(ids)) and np.all(ids >= -1) and np.all(rows[:, 3] > 0) and np.all(rows[:, 5:] == PADDING)
    )


def _parse_line_by_line(rows: list[tuple[int, list[str]]], source: str, strict: bool) -> CourseLog:
    """``parse`` of split lines ``rows`` ((line number, values)), checked one by one."""
    if strict:
        width = len(rows[0][1])
    else:
        width = Counter(len(parts) for _, parts in rows).most_common(1)[0][0]
    accepted: list[tuple[int, list[float]]] = []
    skipped: list[SkippedLine] = []
    previous_time = -math.inf
    for number, parts in rows:
        values, reason = _check_line(parts, width, previous_time, rows[0][0])
        if reason is not None:
            if strict:
                raise LogFormatError(source, number, reason)
            skipped.append(SkippedLine(number, reason))
            continue
        previous_time = values[0]
        accepted.append((number, values))
    if not accepted:
        raise LogFormatError(source, rows[0][0], "no valid record in the log")
    table = np.array([values for _, values in accepted], dtype=float)
    course_log = CourseLog(
        times=table[:, 0],
        flags=table[:, 1].astype(np.int8),
        values=table[:, 2:],
        source=source,
        line_numbers=np.array([number for number, _ in accepted]),
        skipped=skipped,
    )
    return _of_one_kind(course_log, strict)


def _check_line(parts: list[str], width: int, previous_time: float, first_line: int):
    """``(values, None)`` for a valid record's split line, ``(None, reason)`` for an invalid one."""
    if len(parts) != width:
        return None, f"has {len(parts)} values, expected {width} (the width of line {first_line})"
    if width < 3:
        return None, f"a record needs a timestamp, a flag and data, got {width} values"
    try:
        values = [float(v) for v in parts]
    except ValueError:
        column, bad = next((c, v) for c, v in enumerate(parts, 1) if not _is_float(v))
        return None, f"value {bad!r} in column {column} is not a number"
    bad_column = next((c for c, v in enumerate(values, 1) if not math.isfinite(v)), None)
    if bad_column is not None:
        return None, f"value {parts[bad_column - 1]!r} in column {bad_column} is not finite"
    if abs(values[0]) > MAX_TIME:
        return None, f"timestamp {parts[0]!r} is implausibly large (magnitude above {MAX_TIME:g} s)"
    huge = next((c for c, v in enumerate(values[2:], 3) if abs(v) > MAX_VALUE), None)
    if huge is not None:
        return None, f"value {parts[huge - 1]!r} in column {huge} is implausibly large (magnitude above {MAX_VALUE:g})"
    t, flag = values[0], values[1]
    if flag == ODOMETRY:
        if width < 4:
            return None, "an odometry record needs dX and dTheta (4 values at least)"
        wrong = next((c for c, v in enumerate(values[4:], 5) if v != PADDING), None)
        if wrong is not None:
            return None, (
                f"odometry record is not padded with -1 after dX and dTheta (column {wrong} is {parts[wrong - 1]})"
            )
    elif flag == SCAN:
        negative = next((c for c, v in enumerate(values[2:], 3) if v < 0), None)
        if negative is not None:
            return None, f"scan has a negative range {parts[negative - 1]} in column {negative} (beam {negative - 3})"
    elif flag == LANDMARK:
        if width < 5:
            return None, "a landmark record needs id, range and bearing (5 values at least)"
        identity, rng = values[2], values[3]
        if identity != int(identity) or identity < -1:
            return None, f"landmark id {parts[2]} is not an integer >= -1"
        if rng <= 0:
            return None, f"landmark range {parts[3]} is not positive"
        wrong = next((c for c, v in enumerate(values[5:], 6) if v != PADDING), None)
        if wrong is not None:
            return None, (
                "landmark record is not padded with -1 after id, range and bearing "
                f"(column {wrong} is {parts[wrong - 1]})"
            )
    else:
        return None, f"flag {parts[1]} is not 0 (odometry), 1 (scan) or 2 (landmark)"
    if t < previous_time:
        return None, f"timestamp {parts[0]} is earlier than the previous record's {previous_time:.{DECIMALS}f}"
    return values, None


def _is_float(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


class LogWriter:
    """Writes a course log record by record, flushing each line, so nothing recorded is lost.

    Use as a context manager. ``beams`` fixes the width of every line (N ranges per scan).
    """

    def __init__(self, path: str | Path, beams: int):
        if beams < 2:
            raise ValueError(f"a course log needs at least 2 data columns (dX, dTheta), got {beams}")
        self._landmark_padding = " ".join(["-1"] * (beams - 3))
        self.path = Path(path)
        self.beams = beams
        self.previous_time = -math.inf
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._file = self.path.open("w")
        self._padding = " ".join(["-1"] * (beams - 2))

    def __enter__(self) -> LogWriter:
        return self

    def __exit__(self, *exc_info) -> None:
        self.close()

    def close(self) -> None:
        close_written(self._file, self.path)

    def write_odometry(self, t: float, distance: float, turn: float) -> None:
        """One odometry record: ``distance`` metres travelled and ``turn`` radians turned since the last."""
        fields = [f"{t:.{DECIMALS}f}", "0", f"{distance:.{DECIMALS}f}", f"{turn:.{DECIMALS}f}"]
        self._write(t, " ".join(fields + ([self._padding] if self._padding else [])))

    def write_scan(self, t: float, ranges) -> None:
        """One scan record: ``beams`` ranges in metres, 0 for no return."""
        ranges = np.asarray(ranges, dtype=float)
        if ranges.shape != (self.beams,):
            raise ValueError(f"{self.path}: scan has {ranges.shape} ranges, this log takes {self.beams}")
        if not np.all(np.isfinite(ranges)) or np.any(ranges < 0):
            raise ValueError(f"{self.path}: scan ranges must be finite and >= 0 (0 = no return)")
        self._write(t, f"{t:.{DECIMALS}f} 1 " + " ".join(f"{r:.{DECIMALS}f}" for r in ranges))

    def write_landmark(self, t: float, landmark: int, rng: float, bearing: float) -> None:
        """One landmark observation (the extension record, flag 2): identity, range (m), bearing (rad)."""
        if self.beams < 3:
            raise ValueError(f"{self.path}: landmark records need 3 data columns, this log has {self.beams}")
        if rng <= 0 or not np.isfinite([rng, bearing]).all():
            raise ValueError(f"{self.path}: landmark range must be positive and finite, got {rng}, {bearing}")
        fields = [f"{t:.{DECIMALS}f}", "2", str(int(landmark)), f"{rng:.{DECIMALS}f}", f"{bearing:.{DECIMALS}f}"]
        self._write(t, " ".join(fields + ([self._landmark_padding] if self._landmark_padding else [])))

    def _write(self, t: float, line: str) -> None:
        if t < self.previous_time:
            raise ValueError(f"{self.path}: timestamp {t} is earlier than the previous record's {self.previous_time}")
        self.previous_time = t
        write_line(self._file, self.path, line)


def refuse_to_overwrite(inputs, outputs) -> None:
    """Raise ``ValueError`` if any of the files ``outputs`` (an import's log and sidecars) is one of
    the files ``inputs`` it reads (the same path, or the same file by another path or link), or
    would take the place of one that does not exist (a dataset's ``name.dat`` beside the
    ``name.dat.gz`` it reads): writing it would destroy or replace the input."""
    for output in map(Path, outputs):
        for source in map(Path, inputs):
            same = output.resolve() == source.resolve() or (
                output.is_file() and source.is_file() and os.path.samefile(output, source)
            )
            if same:
                named = "" if source == output else f" {source}"
                raise ValueError(
                    f"{output}: is the input file{named}: writing there would overwrite or replace it; "
                    "give another output"
                )


def write(path: str | Path, log: CourseLog) -> None:
    """Write a whole ``CourseLog`` (see ``LogWriter``)."""
    with LogWriter(path, log.width) as writer:
        for record in log.records():
            if isinstance(record, OdometryRecord):
                writer.write_odometry(record.t, record.distance, record.turn)
            elif isinstance(record, ScanRecord):
                writer.write_scan(record.t, record.ranges)
            else:
                writer.write_landmark(record.t, record.landmark, record.range, record.bearing)


def summary(log: CourseLog) -> dict:
    """Counts, duration and travel of a log: what ``mazeslam info`` prints."""
    scans = log.scans
    odometry = log.odometry
    return {
        "source": log.source,
        "records": len(log),
        "odometry_records": int(log.is_odometry.sum()),
        "scan_records": int(log.is_scan.sum()),
        "landmark_records": int(log.is_landmark.sum()),
        "beams": log.n_beams,
        "start_s": float(log.times[0]),
        "duration_s": log.duration,
        "distance_m": float(np.abs(odometry[:, 0]).sum()),
        "net_rotation_rad": float(odometry[:, 1].sum()),
        "total_rotation_rad": float(np.abs(odometry[:, 1]).sum()),
        "no_return_fraction": float((scans == 0).mean()) if scans.size else None,
        "max_range_m": float(scans.max()) if scans.size else None,
        "skipped_lines": len(log.skipped),
    }
