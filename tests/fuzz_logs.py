"""Tiny logs of every kind for the fuzz suite (tests/fuzz/), and the one check every SLAM run there
must pass.

Four kinds, each a handful of records built here from a seed (nothing from ../shared/data):

* ``course``: the exercise robot's kind (like ../shared/data/course/log1.txt): 360 beams at +k
  degrees from a camera 0.11 m ahead of the axle, whole millimetres from 0.11 to 0.4 m, odometry at
  about 4 Hz, no sidecars; odd seeds hold a wheel-counter glitch pair (log1's lines 79-80).
* ``simulated``: ``mazeslam.simulate`` for 2.5 s, with its truth and map sidecars.
* ``carmen``: a CARMEN FLASER/ODOM log of a 6 x 4 m room, imported (``import_carmen``).
* ``mrclam``: an MRCLAM dataset of two landmarks, imported (``import_mrclam``): landmark records.

``edited`` writes a log with its records changed (the edge-sized logs), its truth sidecar changed
alike, so that the log and its truth still fit. ``slam_outcome`` runs the filter the way
``slam_on_file`` does and says "result" (every number finite) or "refused" (one of the project's
clear errors, one line); a traceback or a warning fails the test.
"""

from __future__ import annotations

import math
import shutil
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from conftest import PROJECT_ROOT

from mazeslam.cli.main import KNOWN_ERRORS
from mazeslam.core.config import with_settings
from mazeslam.data import log, sidecars
from mazeslam.data.beam_detection import with_detected_convention
from mazeslam.data.carmen import import_carmen
from mazeslam.data.loaded_run import load_run
from mazeslam.data.mrclam import import_mrclam
from mazeslam.evaluation.scoring import score_run
from mazeslam.pipeline import SlamConfig, load_slam_config, run_slam
from mazeslam.sim.laser import cast_rays

#: Every config of configs/ (the simulator's too: given to slam, they are refused), and None: the defaults.
CONFIGS: list[str | None] = [None, *sorted(path.name for path in (PROJECT_ROOT / "configs").glob("*.toml"))]
MAP_KINDS = ("landmarks", "grid")
ASSOCIATIONS = ("known", "unknown")

# -- the four kinds ---------------------------------------------------------------------------------

#: Walls (W, 4) x1, y1, x2, y2 in metres: the course robot's two maze cells, the CARMEN room with a pillar.
CELLS = np.array(
    [[0, 0, 0.56, 0], [0.56, 0, 0.56, 0.28], [0.56, 0.28, 0, 0.28], [0, 0.28, 0, 0], [0.28, 0, 0.28, 0.14]]
)
ROOM = np.array([[0, 0, 6, 0], [6, 0, 6, 4], [6, 4, 0, 4], [0, 4, 0, 0], [3, 1.5, 3.4, 1.5], [3.4, 1.5, 3.4, 2.0]])


def _ranges(pose, bearings: np.ndarray, walls: np.ndarray, max_range: float, mount: float = 0.0) -> np.ndarray:
    """(N,) ranges (m) of beams at ``bearings`` (N,) (robot frame, rad) from a sensor ``mount`` m ahead
    of ``pose`` (x, y, theta), against ``walls``; 0 beyond ``max_range`` (no return)."""
    x, y, theta = pose
    origin = np.array([x + mount * math.cos(theta), y + mount * math.sin(theta)])
    found = cast_rays(origin, theta + bearings, walls, max_range)
    return np.where(np.isfinite(found) & (found <= max_range), found, 0.0)


def course_log(path: Path, seed: int) -> Path:
    """A course-robot log of 9 records (6 odometry, 3 scans) driving along the two cells; no sidecars."""
    rng = np.random.default_rng(seed)
    bearings = np.deg2rad(np.arange(360))
    pose = np.array([0.1 + 0.02 * rng.random(), 0.14, 0.05 * rng.standard_normal()])
    glitch = seed % 2 == 1
    with log.LogWriter(path, 360) as writer:
        for k in range(9):
            t = 0.073 + 0.25 * k
            if k % 3 == 2:
                ranges = np.round(_ranges(pose, bearings, CELLS, 0.4, mount=0.11), 3)
                writer.write_scan(t, np.where(ranges >= 0.1115, ranges, 0.0))
                continue
            distance, turn = 0.005 + 0.002 * rng.random(), 0.02 * rng.standard_normal()
            pose += [distance * math.cos(pose[2]), distance * math.sin(pose[2]), turn]
            if glitch and k == 3:
                writer.write_odometry(t, distance + 0.0603, turn + 0.849)
            elif glitch and k == 4:
                writer.write_odometry(t, distance - 0.0603, turn - 0.849)
            else:
                writer.write_odometry(t, distance, turn)
    return path


def simulated_log(path: Path, seed: int) -> Path:
    """2.5 s of the simulator in a random 4 x 4 maze: 17 records with truth and map sidecars."""
    from mazeslam import simulate

    simulate(path, seed=seed, duration=2.5, progress=False)
    return path


def carmen_log(path: Path, seed: int) -> Path:
    """A CARMEN log of 4 scans (181 beams) and 8 ODOM messages in ``ROOM``, imported as ``path``."""
    rng = np.random.default_rng(seed)
    bearings = np.deg2rad(np.arange(-90, 91))
    lines = ["PARAM robot_front_laser_max 50.0 nohost 0"]
    pose = np.array([1.0 + rng.random(), 1.0 + rng.random(), 0.3 * rng.standard_normal()])
    for k in range(4):
        for half in (0.25, 0.5):
            odometry = pose + [0.1 * half * math.cos(pose[2]), 0.1 * half * math.sin(pose[2]), 0.0]
            t = k + half
            lines.append(f"ODOM {odometry[0]:.4f} {odometry[1]:.4f} {odometry[2]:.4f} 0 0 0 {t} nohost {t}")
        pose = pose + [0.1 * math.cos(pose[2]), 0.1 * math.sin(pose[2]), 0.05 * rng.standard_normal()]
        ranges = " ".join(f"{r:.3f}" for r in _ranges(pose, bearings, ROOM, 50.0))
        stamped = " ".join(f"{v:.4f}" for v in pose)
        lines.append(f"FLASER 181 {ranges} {stamped} {stamped} {k + 1.0} nohost {k + 1.0}")
    source = path.with_suffix(".carmen")
    source.write_text("\n".join(lines) + "\n")
    import_carmen(source, path)
    return path


def mrclam_log(path: Path, seed: int) -> Path:
    """An MRCLAM robot driving 2 s past two landmarks (4 sightings, one of another robot), imported."""
    rng = np.random.default_rng(seed)
    folder = path.parent / f"{path.stem}-dataset"
    folder.mkdir(parents=True, exist_ok=True)
    speed, turn_rate = 0.1 + 0.05 * rng.random(), 0.2 * rng.standard_normal()
    times = np.arange(0, 2.01, 0.5)
    truth_times = np.arange(-0.5, 2.6, 0.25)
    heading = turn_rate * truth_times
    tables = {
        "Robot1_Odometry.dat": [(t, speed, turn_rate) for t in times],
        "Robot1_Measurement.dat": [
            (0.75, 30, 1.5, 0.1),
            (1.0, 31, 2.0, -0.2),
            (1.25, 14, 1.0, 0.0),
            (1.5, 30, 1.4, 0.05),
        ],
        "Robot1_Groundtruth.dat": [
            (t, speed * t * math.cos(h), speed * t * math.sin(h), h) for t, h in zip(truth_times, heading)
        ],
        "Landmark_Groundtruth.dat": [(6, 1.5, 0.2, 0.001, 0.001), (7, 1.8, -0.4, 0.001, 0.001)],
        "Barcodes.dat": [(2, 14), (6, 30), (7, 31)],
    }
    for name, rows in tables.items():
        (folder / name).write_text(
            "# a tiny MRCLAM table\n" + "\n".join(" ".join(map(str, row)) for row in rows) + "\n"
        )
    import_mrclam(folder, 1, path)
    return path


#: Each kind's builder ``(path, seed) -> path``, and the config written for its kind of log.
LOG_KINDS: dict[str, Callable[[Path, int], Path]] = {
    "course": course_log,
    "simulated": simulated_log,
    "carmen": carmen_log,
    "mrclam": mrclam_log,
}
OWN_CONFIG = {"course": "course.toml", "simulated": "fastslam.toml", "carmen": "carmen.toml", "mrclam": "mrclam.toml"}


def build(kind: str, folder: Path, seed: int) -> Path:
    """The ``kind`` log of ``seed`` in ``folder`` (made once: a later call finds it)."""
    path = folder / f"{kind}{seed}" / f"{kind}{seed}.log"
    if not path.exists():
        path.parent.mkdir(parents=True, exist_ok=True)
        LOG_KINDS[kind](path, seed)
    return path


# -- edits: the edge-sized logs ------------------------------------------------------------------------


@dataclass
class Records:
    """A log's records as arrays to edit: times (R,) s, flags (R,), values (R, W), and the true
    poses (R, 3) when the log has a truth sidecar."""

    times: np.ndarray
    flags: np.ndarray
    values: np.ndarray
    truth: np.ndarray | None

    def take(self, rows) -> Records:
        """These records at ``rows`` (indices or a mask), in that order."""
        rows = np.asarray(rows)
        truth = None if self.truth is None else self.truth[rows]
        return Records(self.times[rows], self.flags[rows], self.values[rows], truth)


def read_records(path: Path) -> Records:
    course_log = log.read(path)
    truth_file = sidecars.truth_path(path)
    truth = sidecars.read_truth(truth_file)[1] if truth_file.exists() else None
    return Records(course_log.times.copy(), course_log.flags.copy(), course_log.values.copy(), truth)


def edited(source: Path, out: Path, edit: Callable[[Records], Records]) -> Path:
    """Write ``out``: the log ``source`` with ``edit`` applied to its records (and its truth alike),
    its map sidecar copied. Lines are written as they are, unchecked: times may go back."""
    records = edit(read_records(source))
    out.parent.mkdir(parents=True, exist_ok=True)
    lines = [
        f"{t:.6f} {flag} " + " ".join(f"{v:.6f}" if v != -1 else "-1" for v in row)
        for t, flag, row in zip(records.times, records.flags.astype(int), records.values)
    ]
    out.write_text("\n".join(lines) + "\n")
    if records.truth is not None:
        sidecars.write_truth(sidecars.truth_path(out), records.times, records.truth)
    if sidecars.map_path(source).exists():
        shutil.copyfile(sidecars.map_path(source), sidecars.map_path(out))
    return out


# -- the check -----------------------------------------------------------------------------------------


def config_for(name: str | None, map_kind: str, association: str) -> SlamConfig:
    """The config ``name`` of configs/ (None: the defaults) with ``[map] kind`` and ``[fastslam]
    association`` replaced, as ``mazeslam slam --map --association`` does."""
    config = SlamConfig() if name is None else load_slam_config(PROJECT_ROOT / "configs" / name)
    return with_settings(config, {"map.kind": map_kind, "fastslam.association": association})


def _finite(name: str, array) -> None:
    array = np.asarray(array, dtype=float)
    assert np.isfinite(array).all(), f"{name} holds {array[~np.isfinite(array)][:5]}"


def slam_outcome(path: Path, config: Callable[[], SlamConfig]) -> str:
    """Run SLAM on the log ``path`` as ``slam_on_file`` does, and score it: "result" when every
    number of the result is finite, "refused" when it stops with one of the project's clear errors
    (``KNOWN_ERRORS``, one line). ``config`` makes the settings (loading a config may itself be refused).
    Anything else (a traceback, a warning: warnings are errors in the tests) fails the test."""
    try:
        settings = config()
        run = with_detected_convention(load_run(path, settings.sensor), settings)
        result = run_slam(run, settings, progress=False)
        score = score_run(run, result, settings.evaluation.match_radius)
    except KNOWN_ERRORS as error:
        message = str(error)
        assert message and "\n" not in message.strip(), f"not one line: {message!r}"
        return "refused"
    records = len(run.log)
    assert result.mean_poses.shape == (records, 3) and result.pose_covariances.shape == (records, 3, 3)
    for name in ("times", "mean_poses", "best_poses", "pose_covariances", "dead_reckoning", "landmarks"):
        _finite(name, getattr(result, name))
    _finite("landmark_covariances", result.landmark_covariances)
    _finite("nis", result.nis)
    if score is not None:
        _finite("alignment", score.alignment)
        _finite("ATE of the mean", [score.rows[score.mean_row][column] for column in ("ate_rmse", "ate_max")])
    return "result"
