"""Where the grid filter's CPU time goes, and the log1 command's: no targets, the figures behind
docs/benchmarks.md's "Where the grid filter's time goes".

1. Per workload, 30 particles, numba's kernels already loaded: log1 (the exercise robot's log,
   configs/course.toml), the first ``ACES_SCANS`` scans of aces and the whole of edmonton and
   freiburg-079 (configs/carmen.toml, as experiments/carmen_grid imports them). The run's CPU time
   (``run_slam``) is split into the laser odometry (``scan_motions``), the matches and proposals of
   all particles (``kernels.match_all``), the map updates (``kernels.integrate_all``, also per
   free-space sample or end point of a processed scan, ``scan_rays``, and particle) and the rest
   (Python: the scan's rays and points, the draws, the weights, resampling). The proposal's stencil
   (27 scored poses a particle) is measured as the run's CPU less that of the same run scoring the
   stencil's centre alone: a measuring device (that run's draws, and so its path, differ).
2. The log1 command (``mazeslam slam log1 --config configs/course.toml``), each part in a fresh
   interpreter (CPU of the finished child processes): the interpreter and numpy, the command line's
   own imports, numba's import with the first compiled function loaded from the cache, matplotlib's
   import, and the whole command; the filter is timed in this process, and the rest (reading the
   log, the figures' drawing, the output files) is what the whole command leaves.

Logs absent from ../shared/data are skipped, saying so. Run: ``python benchmarks/grid_profile.py``
(about 2 CPU minutes; ``--workloads log1 aces`` for some of them).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from contextlib import contextmanager
from pathlib import Path
from unittest import mock

import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench_grid import (  # noqa: E402
    ACES_SCANS,
    CONFIGS,
    COURSE_LOG,
    SHARED,
    child_cpu,
    command_cpu,
    filter_cpu,
    first_scans,
    loaded,
    run_cpu,
)

from mazeslam.data.loaded_run import LoadedRun  # noqa: E402
from mazeslam.gridslam import filter as grid_filter  # noqa: E402
from mazeslam.gridslam import kernels  # noqa: E402
from mazeslam.pipeline import SlamConfig, load_slam_config  # noqa: E402

WORKLOADS = ("log1", "aces", "edmonton", "freiburg-079")


class StageClock:
    """CPU seconds spent in each of some module functions while it is active (``timing``)."""

    def __init__(self):
        self.seconds: dict[str, float] = {}
        self.processed = 0  # scans the filter processed (``GridSlam.process`` calls)
        self.samples = 0  # the processed scans' free-space samples and end points (``scan_rays``)

    def wrapped(self, name: str, function):
        def timed(*args, **kwargs):
            began = time.process_time()
            try:
                return function(*args, **kwargs)
            finally:
                self.seconds[name] = self.seconds.get(name, 0.0) + time.process_time() - began

        return timed

    def counted(self, process):
        def counting(slam, *args, **kwargs):
            self.processed += 1
            return process(slam, *args, **kwargs)

        return counting

    def sampled(self, scan_rays):
        def counting(*args, **kwargs):
            rays = scan_rays(*args, **kwargs)
            self.samples += len(rays.free) + len(rays.hits)
            return rays

        return counting

    @contextmanager
    def timing(self):
        """The laser odometry and the two compiled batches timed (the filter looks them up at call
        time), the processed scans and their rays' samples counted."""
        with (
            mock.patch.object(grid_filter.GridSlam, "process", self.counted(grid_filter.GridSlam.process)),
            mock.patch.object(grid_filter, "scan_rays", self.sampled(grid_filter.scan_rays)),
            mock.patch.object(grid_filter, "scan_motions", self.wrapped("motion", grid_filter.scan_motions)),
            mock.patch.object(kernels, "match_all", self.wrapped("match_all", kernels.match_all)),
            mock.patch.object(kernels, "integrate_all", self.wrapped("integrate_all", kernels.integrate_all)),
        ):
            yield self


def workload(name: str) -> tuple[LoadedRun, SlamConfig] | None:
    """The log and configuration of workload ``name``, or None where its log is absent."""
    if name == "log1":
        if not COURSE_LOG.exists():
            return None
        config = load_slam_config(CONFIGS / "course.toml")
        return loaded(COURSE_LOG, config), config
    from experiments.carmen_grid.run import imported_run, slam_config

    if not (SHARED / "carmen" / f"{name}-corrected.log.gz").exists():
        return None
    run = imported_run(name)
    config = slam_config(run)
    return (first_scans(run, ACES_SCANS) if name == "aces" else run), config


def stage_row(name: str, run: LoadedRun, config: SlamConfig) -> dict:
    """One workload's CPU by stage (module docstring, 1)."""
    run_cpu(run, config)  # numba's compiled kernels loaded first
    clock = StageClock()
    with clock.timing():
        total = run_cpu(run, config)
    with mock.patch.object(grid_filter, "STENCIL", grid_filter.STENCIL[13:14]):  # (0, 0, 0): the centre
        centre_only = run_cpu(run, config)
    motion, matching, updating = (clock.seconds.get(stage, 0.0) for stage in ("motion", "match_all", "integrate_all"))
    particles = config.grid_filter.particles
    return {
        "workload": name if name != "aces" else f"aces (first {ACES_SCANS} scans)",
        "scans / processed": f"{int(run.log.is_scan.sum())} / {clock.processed}",
        "CPU s": total,
        "laser odometry s": motion,
        "match_all s": matching,
        "of which the stencil s": total - centre_only,
        "integrate_all s": updating,
        "samples a scan": clock.samples / max(clock.processed, 1),
        "integrate_all ns per sample and particle": 1e9 * updating / max(clock.samples * particles, 1),
        "rest (Python) s": total - matching - updating - motion,
        "log s": run.log.duration,
        "filter us per particle and processed scan": 1e6 * (total - motion) / (particles * clock.processed),
    }


def command_rows(repeats: int = 3) -> list[dict]:
    """The log1 command's CPU by phase (module docstring, 2), each the least of ``repeats``."""
    config = load_slam_config(CONFIGS / "course.toml")
    log1, particles = loaded(COURSE_LOG, config), config.grid_filter.particles
    filter_cpu(log1, particles)  # numba's compiled kernels loaded first
    filter_seconds = min(filter_cpu(log1, particles) for _ in range(repeats))
    numba_first_call = (
        "import numpy; from mazeslam.gridslam import kernels; "
        "kernels.bounds(numpy.zeros((1, 1, 3)), numpy.zeros((1, 2)), True)"
    )
    with tempfile.TemporaryDirectory() as scratch:
        folder = Path(scratch)
        command_cpu(COURSE_LOG, folder)  # the beam convention's detection cached, as a rerun finds it
        phases = {
            name: min(child_cpu(["-c", code]) for _ in range(repeats))
            for name, code in (
                ("numpy", "import numpy"),
                ("command line", "import mazeslam.cli.main"),
                ("numba", numba_first_call),
                ("matplotlib", "import numpy, matplotlib.figure, matplotlib.backends.backend_agg"),
            )
        }
        whole = min(command_cpu(COURSE_LOG, folder) for _ in range(repeats))
    parts = {
        "the interpreter and numpy": phases["numpy"],
        "the command line's imports (click, the config)": phases["command line"] - phases["numpy"],
        "numba: import, first compiled function loaded": phases["numba"] - phases["numpy"],
        "matplotlib's import": phases["matplotlib"] - phases["numpy"],
        "the filter (run_slam)": filter_seconds,
    }
    parts["the rest: the log read, the figures drawn, the files"] = whole - sum(parts.values())
    rows = [{"phase": name, "CPU s": seconds} for name, seconds in parts.items()]
    return rows + [{"phase": "the whole command", "CPU s": whole}]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workloads", nargs="+", default=list(WORKLOADS), choices=WORKLOADS)
    args = parser.parse_args()
    rows = []
    for name in args.workloads:
        found = workload(name)
        if found is None:
            print(f"{name} skipped: its log is not in {SHARED}")
            continue
        rows.append(stage_row(name, *found))
        print(pd.DataFrame(rows[-1:]).to_markdown(index=False, floatfmt=".3g"), flush=True)
    if rows:
        print("\n" + pd.DataFrame(rows).to_markdown(index=False, floatfmt=".3g"))
    if "log1" in args.workloads and COURSE_LOG.exists():
        print("\n" + pd.DataFrame(command_rows()).to_markdown(index=False, floatfmt=".3g"))


if __name__ == "__main__":
    main()
