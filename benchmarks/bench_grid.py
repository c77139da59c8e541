"""Benchmark: the grid filter (mazeslam.gridslam) with its compiled kernels, against the filter as
it was written before them (tests/gridslam/reference_grid_filter.py: a Python loop over particles,
numpy, and OpenCV's distance transform per particle and scan) timed in the same run. CPU time
(user + system) throughout: the ratios do not depend on what else the machine runs.

1. Per particle and scan: the CPU time of every processed scan's update, over particles times
   scans, on log1 (the exercise robot's log, ../shared/data/course/log1.txt, configs/course.toml,
   30 particles) and on the first ``ACES_SCANS`` scans of aces (configs/carmen.toml, 30
   particles); the same seed and settings for both. Target: at least 20x.
2. ``mazeslam slam log1 --config configs/course.toml``, the whole command in a fresh interpreter
   (imports, numba's start and its compiled functions loaded from the cache, the filter, the
   outputs and the figure), and the filter itself within it. Targets: at most 1.5 s and 0.3 s.
   Also the first run on a machine with no compiled cache (numba compiles the kernels: a new user's
   first run), no target.
3. 1000 particles on log1 (the filter, ``run_slam``). Target: at most 10 s.
4. aces, the whole log, 30 and 300 particles: the log's duration over the filter's CPU time
   (targets at least 150x and 20x), and the peak memory of a process running it, against the same
   run of the reference filter (target: no higher).
5. ``mazeslam slam log1 --live`` with the grid filter (``GridLiveView``): how far a scan's update
   falls behind the log's own clock when the live view plays the log at its pace, off-screen on a
   clock of the CPU spent (``CpuClock``).
   Target: no later than one frame of the view (1 / ``max_fps``).

The CARMEN logs and log1 come from ../shared/data; their rows are skipped, saying so, where it is absent.
Run: ``python benchmarks/bench_grid.py``.
"""

from __future__ import annotations

import dataclasses
import json
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path
from unittest import mock

import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "gridslam"))

from bench_command import children_cpu  # noqa: E402  (CPU of finished child processes)
from reference_grid_filter import ReferenceGridSlam  # noqa: E402

from mazeslam.core.config import with_settings  # noqa: E402
from mazeslam.data.beam_detection import loaded_with_convention  # noqa: E402
from mazeslam.data.carmen import import_carmen  # noqa: E402
from mazeslam.data.loaded_run import LoadedRun, load_run  # noqa: E402
from mazeslam.gridslam import filter as grid_filter  # noqa: E402
from mazeslam.pipeline import SlamConfig, load_slam_config, run_slam  # noqa: E402

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data"
COURSE_LOG = SHARED / "course" / "log1.txt"
ACES = SHARED / "carmen" / "aces-corrected.log.gz"
CONFIGS = Path(__file__).resolve().parents[1] / "configs"
ACES_SCANS = 120
TARGET_PER_SCAN = 20.0
TARGET_COMMAND_SECONDS, TARGET_FILTER_SECONDS = 1.5, 0.3
TARGET_THOUSAND_SECONDS = 10.0
TARGET_ACES = {30: 150.0, 300: 20.0}


class TimedUpdates:
    """Counts the CPU seconds and the particle-scans of every ``process`` of a grid filter class."""

    def __init__(self, slam_type: type):
        self.slam_type, self.seconds, self.particle_scans = slam_type, 0.0, 0

    def __call__(self, *args, **kwargs):
        slam = self.slam_type(*args, **kwargs)
        process = slam.process

        def timed(ranges, motion):
            began = time.process_time()
            update = process(ranges, motion)
            self.seconds += time.process_time() - began
            self.particle_scans += len(slam.poses)
            return update

        slam.process = timed
        return slam


def per_particle_scan(run: LoadedRun, config: SlamConfig, slam_type) -> float:
    """CPU seconds per particle and scan of ``slam_type``'s updates over ``run``."""
    timed = TimedUpdates(slam_type)
    with mock.patch.object(grid_filter, "GridSlam", timed):
        run_slam(run, config, progress=False)
    return timed.seconds / timed.particle_scans


def loaded(path: Path, config: SlamConfig) -> LoadedRun:
    """The log at ``path`` as the slam command loads it (its beam convention detected)."""
    return loaded_with_convention(path, config)


def first_scans(run: LoadedRun, scans: int) -> LoadedRun:
    """``run`` up to its ``scans``-th scan (its records before it and the scan), the rest alike."""
    end = int(run.log.is_scan.nonzero()[0][scans - 1]) + 1
    log = run.log
    cut = dataclasses.replace(log, times=log.times[:end], flags=log.flags[:end], values=log.values[:end])
    return dataclasses.replace(run, log=cut, truth=None if run.truth is None else run.truth[:end])


def ratio_rows(name: str, run: LoadedRun, config: SlamConfig) -> Iterator[dict]:
    """Per particle and scan: the compiled filter against the reference, one row."""
    per_scan = per_particle_scan(run, config, grid_filter.GridSlam)  # also loads numba's cache first
    per_scan = per_particle_scan(run, config, grid_filter.GridSlam)
    reference = per_particle_scan(run, config, ReferenceGridSlam)
    yield {
        "benchmark": f"grid filter per particle and scan, {name}: reference {reference * 1e6:.0f} us, "
        f"compiled {per_scan * 1e6:.0f} us",
        "value": reference / per_scan,
        "unit": "x faster",
        "target": TARGET_PER_SCAN,
        "met": reference / per_scan >= TARGET_PER_SCAN,
    }


def child_cpu(arguments: list[str], environment: dict | None = None) -> float:
    """CPU seconds of a fresh interpreter running ``arguments`` (after ``python``), with
    ``environment`` added to this process's."""
    before = children_cpu()
    subprocess.run(
        [sys.executable, *arguments], check=True, capture_output=True, env={**os.environ, **(environment or {})}
    )
    return children_cpu() - before


def command_cpu(log: Path, folder: Path, environment: dict | None = None) -> float:
    """CPU seconds of ``mazeslam slam LOG --config configs/course.toml`` in a fresh interpreter."""
    command = ["-m", "mazeslam.cli", "slam", str(log), "--config", str(CONFIGS / "course.toml")]
    return child_cpu(command + ["--out", str(folder / "command")], environment)


def run_cpu(run: LoadedRun, config: SlamConfig) -> float:
    """CPU seconds of ``run_slam`` over ``run`` with ``config``."""
    began = time.process_time()
    run_slam(run, config, progress=False)
    return time.process_time() - began


def filter_cpu(run: LoadedRun, particles: int) -> float:
    """CPU seconds of the grid filter's run over ``run`` (``run_slam``, configs/course.toml
    with ``particles``), numba's compiled functions already loaded."""
    return run_cpu(run, with_settings(load_slam_config(CONFIGS / "course.toml"), {"grid.particles": particles}))


def command_rows(folder: Path, log1: LoadedRun) -> Iterator[dict]:
    """The log1 command (numba's cache warm), the filter within it, and the first run without a cache."""
    with tempfile.TemporaryDirectory() as empty_cache:
        first = command_cpu(COURSE_LOG, folder, {"NUMBA_CACHE_DIR": empty_cache})
    command_cpu(COURSE_LOG, folder)  # makes sure the project's own cache is there
    whole = min(command_cpu(COURSE_LOG, folder) for _ in range(3))
    yield {
        "benchmark": "`mazeslam slam log1 --config configs/course.toml`, whole command (CPU)",
        "value": whole,
        "unit": "s",
        "target": TARGET_COMMAND_SECONDS,
        "met": whole <= TARGET_COMMAND_SECONDS,
    }
    filter_seconds = min(filter_cpu(log1, 30) for _ in range(3))
    yield {
        "benchmark": "the same run's filter (run_slam, CPU)",
        "value": filter_seconds,
        "unit": "s",
        "target": TARGET_FILTER_SECONDS,
        "met": filter_seconds <= TARGET_FILTER_SECONDS,
    }
    yield {
        "benchmark": "the same command on a machine's first run (numba compiles the kernels)",
        "value": first,
        "unit": "s",
    }


class CpuClock:
    """A clock for the live view (``FilterView``'s ``clock``) made of the CPU seconds the process
    spends plus the seconds it was asked to wait, which pass at once: the log paced as a window
    paces it, without waiting, on a clock the machine's other work does not move."""

    def __init__(self):
        self.started, self.waited = time.process_time(), 0.0

    def now(self) -> float:
        return time.process_time() - self.started + self.waited

    def wait(self, seconds: float) -> None:
        self.waited += seconds


def live_row(log1: LoadedRun, course: SlamConfig) -> dict:
    from mazeslam.viz.live import GridLiveView

    run_slam(log1, course, progress=False)  # numba's kernels loaded, as a second run finds them
    with mock.patch.dict(os.environ, {"MPLBACKEND": "Agg"}):  # off-screen even where a display is
        view = GridLiveView(log1, "live view (bench)", clock=CpuClock())
    run_slam(log1, course, progress=False, on_update=view)
    view.close(keep_open=False)
    lag, frame = max(view.lateness[1:]), 1.0 / view.max_fps  # the first scan starts the clock: on time
    return {
        "benchmark": f"`mazeslam slam log1 --live` (grid filter, the log's pace, {view.frames} frames): "
        "the latest a scan's update ends after its time in the log (negative: early)",
        "value": lag,
        "unit": "s",
        "target": frame,
        "met": lag <= frame,
    }


def thousand_particles_row(log1: LoadedRun) -> dict:
    seconds = filter_cpu(log1, 1000)
    return {
        "benchmark": "1000 particles on log1 (configs/course.toml), the filter (CPU)",
        "value": seconds,
        "unit": "s",
        "target": TARGET_THOUSAND_SECONDS,
        "met": seconds <= TARGET_THOUSAND_SECONDS,
    }


_WHOLE_LOG = """
import json, resource, sys, time
from unittest import mock
sys.path.insert(0, {tests!r})
from reference_grid_filter import ReferenceGridSlam
from mazeslam.core.config import with_settings
from mazeslam.gridslam import filter as grid_filter
from mazeslam.pipeline import load_slam_config, slam_on_file
config = with_settings(load_slam_config({config!r}), {{"grid.particles": {particles}}})
slam_type = ReferenceGridSlam if {reference} else grid_filter.GridSlam
with mock.patch.object(grid_filter, "GridSlam", slam_type):
    began = time.process_time()
    slam_on_file({log!r}, config, progress=False)
    cpu = time.process_time() - began
print(json.dumps({{"cpu": cpu, "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}}))
"""


def whole_log(log: Path, particles: int, reference: bool) -> dict:
    """CPU seconds and peak memory (MB) of a process running the grid filter over ``log``."""
    script = _WHOLE_LOG.format(
        tests=str(Path(__file__).resolve().parents[1] / "tests" / "gridslam"),
        config=str(CONFIGS / "carmen.toml"),
        particles=particles,
        reference=reference,
        log=str(log),
    )
    output = subprocess.run([sys.executable, "-c", script], check=True, capture_output=True, text=True).stdout
    return json.loads(output.strip().splitlines()[-1])


def aces_rows(folder: Path) -> Iterator[dict]:
    import_carmen(ACES, folder / "aces.log")
    run = load_run(folder / "aces.log")
    config = load_slam_config(CONFIGS / "carmen.toml")
    first = first_scans(loaded(run.path, config), ACES_SCANS)
    yield from ratio_rows(f"aces (first {ACES_SCANS} scans, 30 particles)", first, config)
    reference = whole_log(run.path, 30, reference=True)
    for particles, target in TARGET_ACES.items():
        compiled = whole_log(run.path, particles, reference=False)
        factor = run.log.duration / compiled["cpu"]
        yield {
            "benchmark": f"aces, {particles} particles: real time over the run's CPU time (laser odometry included)",
            "value": factor,
            "unit": "x real time",
            "target": target,
            "met": factor >= target,
        }
        if particles == 30:
            yield {
                "benchmark": f"aces, 30 particles: peak memory (reference filter {reference['peak_mb']:.0f} MB)",
                "value": compiled["peak_mb"],
                "unit": "MB",
                "target": reference["peak_mb"],
                "met": compiled["peak_mb"] <= reference["peak_mb"],
            }


def run() -> Iterator[dict]:
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        if COURSE_LOG.exists():
            course = load_slam_config(CONFIGS / "course.toml")
            log1 = loaded(COURSE_LOG, course)
            yield from ratio_rows("log1 (30 particles)", log1, course)
            yield from command_rows(folder, log1)
            yield thousand_particles_row(log1)
            yield live_row(log1, course)
        else:
            print(f"grid benchmarks on log1 skipped: no course log at {COURSE_LOG}")
        if ACES.exists():
            yield from aces_rows(folder)
        else:
            print(f"grid benchmarks on aces skipped: no CARMEN log at {ACES}")


if __name__ == "__main__":
    for row in run():
        print(pd.DataFrame([row]).set_index("benchmark").to_markdown(floatfmt=".3g"), flush=True)
