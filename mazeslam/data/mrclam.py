"""Import one robot of the UTIAS MRCLAM datasets (Leung et al. 2011) as a course log with truth.

Inputs (``.dat`` or ``.dat.gz`` in the dataset folder, '#' comments):

* ``RobotK_Odometry.dat``: time [s], forward velocity [m/s], angular velocity [rad/s];
* ``RobotK_Measurement.dat``: time [s], barcode, range [m], bearing [rad];
* ``RobotK_Groundtruth.dat``: time [s], x, y, orientation (Vicon);
* ``Landmark_Groundtruth.dat``: subject, x, y, std x, std y; ``Barcodes.dat``: subject, barcode.

Output, beside ``out``: the course log (odometry records and landmark observation records, flag
2, with the landmark's subject number as its identity), ``*.truth.csv`` (Vicon pose interpolated
at every record; a record outside the Vicon's time span gets the pose at its nearer end and is
counted, and truth that does not overlap the odometry at all is refused) and ``*.map.json``
(``corners``: the surveyed landmarks; ``landmark_ids``; no walls). Each velocity sample holds until
the next; an odometry record is written at every odometry sample and right before every
measurement, integrating the velocities exactly up to it.
Measurements of other robots (subjects 1-5) and of unknown barcodes are left out and counted.
Rows of the odometry, measurement and truth tables out of time order are sorted into it (stably)
and counted; an empty table other than the measurements is refused.
An output that is one of the input files is refused before anything is read.
"""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import numpy as np

from mazeslam.core.config import read_text
from mazeslam.core.geometry import wrap_angle
from mazeslam.core.outputs import staged_file
from mazeslam.data import sidecars
from mazeslam.data.log import BYTE_ORDER_MARK, MAX_TIME, LogWriter, refuse_to_overwrite

ROBOT_SUBJECTS = range(1, 6)


def _found(folder: Path, name: str) -> Path | None:
    """The file ``name`` or ``name.gz`` in ``folder`` (the plain one first), or None."""
    return next((candidate for candidate in (folder / name, folder / f"{name}.gz") if candidate.exists()), None)


def _table(folder: Path, name: str, columns: int) -> np.ndarray:
    candidate = _found(folder, name)
    if candidate is None:
        raise FileNotFoundError(f"{folder}: neither {name} nor {name}.gz found")
    text = read_text(candidate, "MRCLAM table").removeprefix(BYTE_ORDER_MARK)
    rows = [line for line in text.splitlines() if line.split("#", 1)[0].strip()]
    if not rows:  # (numpy would warn "input contained no data")
        return np.empty((0, columns))
    try:
        table = np.loadtxt(rows, comments="#", ndmin=2)
    except ValueError as error:
        raise ValueError(f"{candidate}: {str(error)[:200]}") from error
    if table.shape[1] != columns:
        raise ValueError(f"{candidate}: expected {columns} columns, found {table.shape[1]}")
    if not np.all(np.isfinite(table)) or np.abs(table).max(initial=0) > MAX_TIME:
        raise ValueError(f"{candidate}: holds a value that is not a finite number of sane size")
    return table


def import_mrclam(folder: str | Path, robot: int, out: str | Path) -> dict:
    """Write robot ``robot``'s log, truth and map sidecars to ``out``; return counts of what was written."""
    folder, out = Path(folder), Path(out)
    if robot not in ROBOT_SUBJECTS:
        raise ValueError(f"MRCLAM robots are numbered 1 to 5, got {robot}")
    names = [f"Robot{robot}_{kind}.dat" for kind in ("Odometry", "Measurement", "Groundtruth")]
    names += ["Landmark_Groundtruth.dat", "Barcodes.dat"]
    refuse_to_overwrite(
        [folder / f"{name}{end}" for name in names for end in ("", ".gz")],
        [out, sidecars.truth_path(out), sidecars.map_path(out)],
    )
    tables = [_table(folder, name, columns) for name, columns in zip(names, (3, 4, 4, 5, 2))]
    for name, table in zip(names, tables):
        if not len(table) and name != names[1]:  # a robot may see nothing; it cannot have no odometry
            raise ValueError(f"{_found(folder, name)}: holds no data rows")
    reordered = {name: _out_of_order(table[:, 0]) for name, table in zip(names[:3], tables)}
    odometry, measurements, truth = (table[np.argsort(table[:, 0], kind="stable")] for table in tables[:3])
    landmarks, barcodes = tables[3:]
    subject_of = {int(barcode): int(subject) for subject, barcode in barcodes}
    skipped: Counter[str] = Counter()
    kept = []
    for t, barcode, rng, bearing in measurements:
        subject = subject_of.get(int(barcode))
        if subject is None:
            skipped["unknown barcode"] += 1
        elif subject in ROBOT_SUBJECTS:
            skipped["another robot"] += 1
        elif not odometry[0, 0] <= t <= odometry[-1, 0]:
            skipped["outside the odometry's time span"] += 1
        else:
            kept.append((t, subject, rng, bearing))
    kept.sort()
    times = np.unique(np.concatenate([odometry[:, 0], [m[0] for m in kept]]))
    _check_overlap(_found(folder, names[2]) or folder / names[2], truth[:, 0], times)
    with staged_file(out) as staged:  # a full disk or an interrupt leaves the last import as it was
        record_times = _write_log(staged, times, odometry, kept)
        poses = _interpolate_poses(truth, record_times)
        sidecars.write_truth(sidecars.truth_path(staged), record_times, poses)
        sidecars.write_map(
            sidecars.map_path(staged),
            walls=np.empty((0, 4)),
            corners=landmarks[:, 1:3],
            sensor={"kind": "landmark range and bearing (monocular camera with barcodes)"},
            landmark_ids=landmarks[:, 0].astype(int).tolist(),
            start_pose=poses[0].tolist(),
            source={"dataset": str(folder), "robot": robot, "ground_truth": "Vicon motion capture"},
        )
    return {
        "records": len(record_times),
        "odometry_records": len(times),
        "landmark_records": len(kept),
        "skipped": dict(skipped),
        "outside_truth": int(np.sum((record_times < truth[0, 0]) | (record_times > truth[-1, 0]))),
        "sorted": {name: count for name, count in reordered.items() if count},
    }


def _write_log(out: Path, times: np.ndarray, odometry: np.ndarray, kept: list) -> np.ndarray:
    """Write the course log ``out``: an odometry record at each of ``times`` (R,) (s), integrating
    the velocity samples ``odometry`` (K, 3: t, m/s, rad/s; each holds until the next) up to it, and
    after it the measurements ``kept`` (t, subject, m, rad) taken then. Returns every record's time."""
    records = []
    with LogWriter(out, beams=3) as writer:
        sample = 0
        pending = iter(kept)
        measurement = next(pending, None)
        pose_time = times[0]
        for t in times:
            while sample + 1 < len(odometry) and odometry[sample + 1, 0] <= pose_time:
                sample += 1
            speed, turn_rate = odometry[sample, 1], odometry[sample, 2]
            dt = t - pose_time
            writer.write_odometry(t, speed * dt, turn_rate * dt)
            records.append(t)
            pose_time = t
            while measurement is not None and measurement[0] == t:
                writer.write_landmark(t, measurement[1], measurement[2], measurement[3])
                records.append(t)
                measurement = next(pending, None)
    return np.array(records)


def _out_of_order(times: np.ndarray) -> int:
    """How many of ``times`` (T,) (s) come after a later time: the rows the import puts back in time
    order (a stable sort; the interpolation and the odometry's integration need rising times)."""
    return int(np.sum(times < np.maximum.accumulate(times))) if len(times) else 0


def _check_overlap(truth_file: Path, truth_times: np.ndarray, record_times: np.ndarray) -> None:
    """Refuse truth whose times (T,) do not overlap the records' (R,) (seconds): every record would
    get the pose at one end of it, one constant pose for the whole run."""
    first, last = max(truth_times[0], record_times[0]), min(truth_times[-1], record_times[-1])
    if not first < last:
        raise ValueError(
            f"{truth_file}: the truth spans t {truth_times[0]:.3f} to {truth_times[-1]:.3f} s and the odometry "
            f"t {record_times[0]:.3f} to {record_times[-1]:.3f} s: they do not overlap, so no record would get "
            "a true pose (files of different runs?)"
        )


def _interpolate_poses(truth: np.ndarray, times: np.ndarray) -> np.ndarray:
    """Vicon poses (x, y, theta) at ``times``, linearly interpolated (theta unwrapped); a time outside
    its span gets the pose at the nearer end (the import counts those records and requires an overlap)."""
    heading = np.unwrap(truth[:, 3])
    return np.column_stack(
        [
            np.interp(times, truth[:, 0], truth[:, 1]),
            np.interp(times, truth[:, 0], truth[:, 2]),
            wrap_angle(np.interp(times, truth[:, 0], heading)),
        ]
    )
