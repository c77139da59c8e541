"""Parameter sweeps: a TOML grid of simulator and filter settings times seeds, run in parallel,
one tidy table out, resumable.

A sweep file::

    name = "particles"
    seeds = [0, 1, 2]
    maze = "random"                          # or a maze file
    simulation_config = "configs/simulation.toml"   # optional base settings
    slam_config = "configs/fastslam.toml"           # optional base settings

    [grid]
    "slam.fastslam.NPARTICLES" = [5, 100, 1000]
    "sim.laser.range_noise_std" = [0.001, 0.003]

Grid keys name a setting by its place: ``sim.<section>.<name>`` in the simulator's config
(sections robot, laser, odometry, logger, drive, maze), ``slam.<section>.<name>`` in the slam
config (map, fastslam, grid, grid.grid, grid.match, corners, corners.lines, sensor, odometry,
scan_matching, evaluation): ``"slam.map.kind" = ["landmarks", "grid"]`` runs both filters, and a
filter's settings may be varied only where some run uses that filter. Settings that move together
are linked with ``+`` and take lists of values, one per setting::

    "slam.fastslam.sigmaR+slam.fastslam.sigmaB" = [[0.001, 0.006], [0.003, 0.017], [0.01, 0.05]]

(in the table such a cell's value is written ``0.001/0.006``). Every combination of
the grid's values runs once per seed: simulate (seeded), then the filter ``[map] kind`` names
(seeded alike, ``mazeslam.pipeline.run_slam``), then the metrics against the truth. Each
finished run is appended at once to ``runs.jsonl`` in the output folder, so an interrupted sweep
resumes where it stopped; the same seeds give the same table.

An interrupted sweep leaves nothing running: stopped by an exception (Ctrl-C, or SIGTERM when the
command line turns it into one), it ends its workers at once instead of waiting for the runs they
are running (whose rows are not written: a resumed sweep runs them again); killed outright, its
workers notice and end (``mazeslam.sweeps.pool.end_with_parent``).
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import importlib
import itertools
import json
import math
import os
import socket
import tempfile
import time
import tomllib
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd
from tqdm.auto import tqdm

from mazeslam.core.config import ConfigError, InputError, check_setting, jsonable, read_text, with_settings
from mazeslam.core.limits import MAX_SEED, duration_problem
from mazeslam.core.outputs import write_file, written
from mazeslam.data.loaded_run import load_run
from mazeslam.evaluation.metrics import apply_se2
from mazeslam.evaluation.scoring import DEAD_RECKONING, score_run
from mazeslam.pipeline import MapKind, SlamConfig, load_slam_config, run_slam
from mazeslam.sim.simulator import SimulationConfig, load_config, simulate
from mazeslam.smoothing.optimum import has_optimum, optimum_columns, optimum_poses
from mazeslam.sweeps.pool import ends_with_this_process

RESULTS = "runs.jsonl"
MAPS = "maps"
#: Runs of one sweep (grid cells times seeds).
MAX_RUNS = 100_000


@dataclass(frozen=True)
class Sweep:
    """A parsed sweep file: the grid, the seeds and the base settings (paths relative to the file)."""

    name: str
    grid: dict[str, list]
    seeds: list[int]
    maze: str = "random"
    simulation_config: str | None = None
    slam_config: str | None = None
    duration: float | None = None
    source: str = "<memory>"
    #: The base configs, read once per Sweep (they are immutable): a sweep's keys and run names ask
    #: for them several times per run, and reading and checking the TOML files took ~3 ms a time.
    _bases: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    def runs(self) -> list[dict]:
        """Every run: ``{"settings": {key: value}, "seed": s}`` in a stable order."""
        keys = list(self.grid)
        combos = itertools.product(*(self.grid[k] for k in keys))
        return [{"settings": dict(zip(keys, values)), "seed": seed} for values in combos for seed in self.seeds]

    def base_simulation(self) -> SimulationConfig:
        if "simulation" not in self._bases:
            self._bases["simulation"] = load_config(self.simulation_config)
        return self._bases["simulation"]

    def base_slam(self) -> SlamConfig:
        if "slam" not in self._bases:
            self._bases["slam"] = load_slam_config(self.slam_config)
        return self._bases["slam"]


def load_sweep(path: str | Path) -> Sweep:
    """Read and check a sweep file; every grid key must name an existing setting."""
    path = Path(path)
    try:
        document = tomllib.loads(read_text(path, "sweep file"))
    except (FileNotFoundError, InputError) as error:
        raise ConfigError(str(error)) from error
    except tomllib.TOMLDecodeError as error:
        raise ConfigError(f"{path}: not valid TOML: {error}") from error
    known = {"name", "seeds", "maze", "simulation_config", "slam_config", "duration", "grid"}
    unknown = sorted(set(document) - known)
    if unknown:
        raise ConfigError(f"{path}: unknown key(s) {', '.join(unknown)}; known: {', '.join(sorted(known))}")
    grid = document.get("grid", {})
    if not isinstance(grid, dict) or not all(isinstance(v, list) and v for v in grid.values()):
        raise ConfigError(f"{path}: [grid] must map setting names to non-empty lists of values")
    seeds = document.get("seeds", [0])
    if (
        not isinstance(seeds, list)
        or not seeds
        or not all(isinstance(s, int) and not isinstance(s, bool) and 0 <= s <= MAX_SEED for s in seeds)
    ):
        raise ConfigError(f"{path}: seeds must be a non-empty list of integers in 0..{MAX_SEED}")
    for key in ("name", "maze", "simulation_config", "slam_config"):
        if key in document and not isinstance(document[key], str):
            raise ConfigError(f"{path}: {key} = {document[key]!r}: must be a text")
    if "duration" in document:
        check_setting(float, "duration", document["duration"], str(path))
        problem = duration_problem(document["duration"]) if document["duration"] > 0 else "must be positive"
        if problem:
            raise ConfigError(f"{path}: duration = {document['duration']!r}: {problem}")
    runs = math.prod(len(values) for values in grid.values()) * len(seeds)
    if runs > MAX_RUNS:
        raise ConfigError(f"{path}: the grid and seeds make {runs} runs; at most {MAX_RUNS}")
    base = path.parent

    def resolve(name):
        value = document.get(name)
        if value is None:
            return None
        candidate = Path(value)
        return str(candidate if candidate.is_absolute() or candidate.exists() else base / candidate)

    maze = document.get("maze", "random")
    sweep = Sweep(
        name=document.get("name", path.stem),
        grid=grid,
        seeds=seeds,
        maze=maze if maze == "random" else resolve("maze"),
        simulation_config=resolve("simulation_config"),
        slam_config=resolve("slam_config"),
        duration=document.get("duration"),
        source=str(path),
    )
    for run in sweep.runs()[: max(1, len(sweep.seeds))]:
        try:
            configure(sweep, run["settings"])
        except (ConfigError, ValueError, TypeError) as error:
            raise ConfigError(f"{path}: {error}") from error
    _check_filter_settings(sweep, path)
    return sweep


#: The settings of each filter, as sweep keys start, and the map kind that runs it.
FILTER_SETTINGS = {"slam.grid.": MapKind.GRID, "slam.fastslam.": MapKind.LANDMARKS}


def _check_filter_settings(sweep: Sweep, path: Path) -> None:
    """Refuse a sweep that varies a filter's settings when none of its runs uses that filter (a grid
    filter setting where every run maps landmarks, or the reverse): its cells would differ in name only."""
    kinds = set(sweep.grid.get("slam.map.kind", [sweep.base_slam().map.kind]))
    for key in sweep.grid:
        for prefix, kind in FILTER_SETTINGS.items():
            if key.startswith(prefix) and kind not in {MapKind(k) for k in kinds}:
                raise ConfigError(
                    f"{path}: [grid] varies {key!r}, a setting of the {kind.filter_name}, but every run maps "
                    f"{', '.join(sorted(map(str, kinds)))} ([map] kind of {sweep.slam_config or 'the defaults'}): "
                    f'add "slam.map.kind" = ["{kind}"] or a slam_config whose [map] kind is "{kind}"'
                )


def configure(sweep: Sweep, settings: dict) -> tuple[SimulationConfig, SlamConfig]:
    """The simulator and slam configs of one grid cell."""
    simulation, slam = sweep.base_simulation(), sweep.base_slam()
    for key, value in _unlinked(settings):
        scope, _, place = key.partition(".")
        if scope == "sim":
            simulation = with_settings(simulation, {place: value})
        elif scope == "slam":
            slam = with_settings(slam, {place: value})
        else:
            raise ConfigError(f"grid key {key!r} must start with 'sim.' or 'slam.'")
    return simulation, slam


def _unlinked(settings: dict):
    """(key, value) for every single setting, linked keys (``a+b``) split into their parts."""
    for key, value in settings.items():
        keys = key.split("+")
        if len(keys) == 1:
            yield key, value
            continue
        if not isinstance(value, list) or len(value) != len(keys):
            raise ConfigError(f"linked grid key {key!r} needs lists of {len(keys)} values, got {value!r}")
        yield from zip(keys, value)


def cell_label(value) -> object:
    """A grid value as it goes into the table: linked values joined by '/'."""
    return "/".join(f"{v:g}" if isinstance(v, float) else str(v) for v in value) if isinstance(value, list) else value


def run_id(sweep: Sweep, run: dict) -> str:
    """A stable name for one run: a hash of its settings, seed and the sweep's base settings."""
    identity = {
        "settings": run["settings"],
        "seed": run["seed"],
        "maze": sweep.maze,
        "duration": sweep.duration,
        "simulation": dataclasses.asdict(sweep.base_simulation()),
        "slam": dataclasses.asdict(sweep.base_slam()),
    }
    text = json.dumps(identity, sort_keys=True, default=str)
    return hashlib.sha1(text.encode()).hexdigest()[:16]


def simulation_key(sweep: Sweep, run: dict) -> str:
    """A stable name for a run's simulation: a hash of the simulator settings, maze, seed and
    duration. Runs that differ only in filter settings share it (the core grid: 27 cells, one log
    per seed)."""
    simulation_config, _ = configure(sweep, run["settings"])
    identity = {
        "simulation": dataclasses.asdict(simulation_config),
        "maze": sweep.maze,
        "seed": run["seed"],
        "duration": sweep.duration,
    }
    return hashlib.sha1(json.dumps(identity, sort_keys=True, default=str).encode()).hexdigest()[:16]


def simulate_run(sweep: Sweep, run: dict, logs_folder: str) -> str:
    """Simulate ``run``'s log (with sidecars) into ``logs_folder``/<simulation key>/ and return
    the key. Runs in a worker."""
    simulation_config, _ = configure(sweep, run["settings"])
    key = simulation_key(sweep, run)
    simulate(
        Path(logs_folder, key, "run.log"), simulation_config, sweep.maze, run["seed"], sweep.duration, progress=False
    )
    return key


def optimum_key(sweep: Sweep, run: dict) -> str:
    """A stable name for a run's batch optimum: its log (``simulation_key``), the map kind and the slam
    settings the optimum uses: for corners all but the filters' particle counts and seeds, the grid
    filter's and the pose graph's settings (the core grid's three particle counts share one optimum
    per noise setting and seed); for a grid all but the filters' (the pose graph's own: a simulated
    log has odometry, so its graph does not start from the grid filter's path, ``[posegraph] grid_start``)."""
    _, slam_config = configure(sweep, run["settings"])
    settings = dataclasses.asdict(slam_config)
    del settings["grid"], settings["map"]
    if slam_config.map.kind == MapKind.GRID:
        del settings["fastslam"], settings["corners"]
    else:
        del settings["fastslam"]["NPARTICLES"], settings["fastslam"]["seed"], settings["posegraph"]
    identity = {"log": simulation_key(sweep, run), "kind": str(slam_config.map.kind), "slam": settings}
    return hashlib.sha1(json.dumps(identity, sort_keys=True, default=str).encode()).hexdigest()[:16]


def _optimum_path(sweep: Sweep, run: dict, logs_folder: str) -> Path:
    return Path(logs_folder, simulation_key(sweep, run), f"optimum-{optimum_key(sweep, run)}.npy")


def optimum_run(sweep: Sweep, run: dict, logs_folder: str) -> None:
    """Compute the batch optimum of ``run``'s log (written by ``simulate_run`` into ``logs_folder``) with
    ``run``'s settings (``optimum_poses``), and save its poses at every record, (R, 3), beside the log
    for ``execute_run`` (nothing when the log has no optimum: ``has_optimum``). Runs in a worker."""
    _, slam_config = configure(sweep, run["settings"])
    loaded = load_run(Path(logs_folder, simulation_key(sweep, run), "run.log"), slam_config.sensor)
    if has_optimum(loaded, slam_config):
        np.save(_optimum_path(sweep, run, logs_folder), optimum_poses(loaded, slam_config))


def execute_run(sweep: Sweep, run: dict, maps_folder: str | None = None, logs_folder: str | None = None) -> dict:
    """Simulate (or, with ``logs_folder``, read the log ``simulate_run`` wrote there, and the
    optimum ``optimum_run`` saved beside it), map and score one run; returns its row (settings,
    seed, metrics). Runs in a worker."""
    simulation_config, slam_config = configure(sweep, run["settings"])
    seed = run["seed"]
    slam_config = slam_config.with_seed(seed)
    optimum_poses = None
    if logs_folder is not None:
        loaded = load_run(Path(logs_folder, simulation_key(sweep, run), "run.log"), slam_config.sensor)
        saved = _optimum_path(sweep, run, logs_folder)
        optimum_poses = np.load(saved) if saved.exists() else None
    else:
        with tempfile.TemporaryDirectory() as folder:
            simulated = simulate(
                Path(folder) / "run.log", simulation_config, sweep.maze, seed, sweep.duration, progress=False
            )
            loaded = load_run(simulated.log_path, slam_config.sensor)
    started = time.perf_counter()
    result = run_slam(loaded, slam_config, progress=False)
    seconds = time.perf_counter() - started
    score = score_run(loaded, result, slam_config.evaluation.match_radius)
    truth, walls = loaded.truth, loaded.walls
    # The simulator writes the truth and map sidecars of every run.
    assert score is not None and truth is not None and walls is not None
    filter_row, reckoning_row = score.rows[score.mean_row], score.rows[DEAD_RECKONING]
    no_map_error = {"rmse": np.nan, "precision": np.nan, "recall": np.nan, "matched": 0}
    map_error = score.map_errors.get("as estimated", no_map_error)  # a grid map is not scored by landmarks
    aligned_map_error = score.map_errors.get("aligned", no_map_error)
    particles = slam_config.particles
    reports = result.reports
    row = {
        "run_id": run_id(sweep, run),
        "seed": seed,
        **{k: cell_label(v) for k, v in run["settings"].items()},
        "ate_rmse": filter_row["ate_rmse"],
        "ate_aligned_rmse": filter_row["aligned_rmse"],
        "reckoning_ate_rmse": reckoning_row["ate_rmse"],
        "reckoning_ate_aligned_rmse": reckoning_row["aligned_rmse"],
        **(optimum_columns(loaded, slam_config, score, optimum_poses) or {}),
        "rpe_trans_rmse": filter_row["rpe_trans_rmse"],
        "rpe_rot_rmse": filter_row["rpe_rot_rmse"],
        "map_rmse": map_error["rmse"],
        "map_aligned_rmse": aligned_map_error["rmse"],
        "map_precision": aligned_map_error["precision"],
        "map_recall": aligned_map_error["recall"],
        "landmarks": len(result.landmarks),
        "spurious_landmarks": len(result.landmarks) - aligned_map_error["matched"],
        "true_corners": len(loaded.true_corners),
        "ess_median": float(np.median([r.effective_sample_size for r in reports])) if reports else np.nan,
        "new_per_scan": float(np.mean([r.new for r in reports])) / particles if reports else np.nan,
        "ambiguous_per_scan": float(np.mean([r.ambiguous for r in reports])) / particles if reports else np.nan,
        "median_nees": filter_row["median_nees"],
        "mean_nees": filter_row["mean_nees"],
        "nees_inside_95": score.nees_summary["inside_95"],
        **{f"nis_{key}": value for key, value in result.nis_summary().items() if key in ("mean", "inside_95")},
        "resampled_fraction": result.resampled_fraction,
        "resamplings": result.resamplings,
        "scans": result.updates,
        "slam_seconds": seconds,
        "log_seconds": loaded.log.duration,
        "seconds_per_record": seconds / len(loaded.log),
    }
    if maps_folder is not None:
        aligned_landmarks = apply_se2(score.alignment, result.landmarks) if len(result.landmarks) else result.landmarks
        document = {
            "landmarks": aligned_landmarks.tolist(),
            "walls": walls.tolist(),
            "corners": loaded.true_corners.tolist(),
            "trajectory": apply_se2(score.alignment, result.mean_poses)[:, :2].round(5).tolist(),
            "truth": truth[:, :2].round(5).tolist(),
        }
        # Written beside and renamed (write_file): a worker killed mid-write leaves no torn map.
        write_file(Path(maps_folder, f"{row['run_id']}.json"), json.dumps(document, allow_nan=False))
    return row


def finished_runs(out_dir: Path, problems: list[str] | None = None) -> dict[str, dict]:
    """The rows already in ``runs.jsonl`` by run id. A line that is not a result (cut off by a
    crash, not JSON, JSON that is not an object with a run_id) is skipped; unless it is a torn last
    line, why is appended to ``problems`` (``file:line: reason``)."""
    path = out_dir / RESULTS
    rows: dict[str, dict] = {}
    if not path.exists():
        return rows
    try:
        text = read_text(path, "sweep results file")
    except InputError as error:
        raise ConfigError(f"{error}; move it away to start the sweep afresh") from error
    lines = text.splitlines()
    for number, line in enumerate(lines, start=1):
        if not line.strip():
            continue
        try:
            row = json.loads(line)
        except (json.JSONDecodeError, RecursionError):
            if problems is not None and number < len(lines):  # the last line: a torn write, expected
                problems.append(f"{path}:{number}: skipped: not JSON")
            continue
        if not isinstance(row, dict) or not isinstance(row.get("run_id"), str):
            if problems is not None:
                shown = line if len(line) <= 40 else line[:37] + "..."
                problems.append(f"{path}:{number}: skipped: not a result (an object with a run_id): {shown}")
            continue
        rows[row["run_id"]] = row
    return rows


@dataclass
class SweepReport:
    """What ``run_sweep`` did."""

    table: pd.DataFrame
    ran: int
    reused: int
    seconds: float
    paths: dict = field(default_factory=dict)
    skipped: list[str] = field(default_factory=list)


def run_sweep(
    sweep: Sweep, out_dir: str | Path, workers: int | None = None, scheduler: str | None = None, progress: bool = True
) -> SweepReport:
    """Run every run of ``sweep`` not yet in ``out_dir``, in parallel, and write the tables.

    ``workers`` local processes (default: one per core), or the Dask cluster at ``scheduler``
    (e.g. ``tcp://host:8786``). Returns the whole table (old and new rows).
    """
    out_dir = Path(out_dir)
    (out_dir / MAPS).mkdir(parents=True, exist_ok=True)
    with SweepLock(out_dir):
        write_file(
            out_dir / "sweep.json",
            json.dumps(
                jsonable({"name": sweep.name, "source": sweep.source, "grid": sweep.grid, "seeds": sweep.seeds}),
                indent=1,
                allow_nan=False,
            )
            + "\n",
        )
        skipped: list[str] = []
        done = finished_runs(out_dir, skipped)
        pending = [run for run in sweep.runs() if run_id(sweep, run) not in done]
        started = time.perf_counter()
        bar = tqdm(
            total=len(done) + len(pending),
            initial=len(done),
            desc=f"sweep {sweep.name}",
            unit="run",
            disable=not progress,
        )
        with (out_dir / RESULTS).open("a") as results:
            if results.tell() and not (out_dir / RESULTS).read_bytes().endswith(b"\n"):
                results.write("\n")  # after a torn last line, the next result starts a line of its own
            # Stopped early, the workers end here, under the lock (not once the generator is collected).
            with contextlib.closing(_execute(sweep, pending, str(out_dir / MAPS), workers, scheduler)) as rows:
                for row in rows:
                    results.write(json.dumps(jsonable(row), allow_nan=False) + "\n")
                    results.flush()
                    done[row["run_id"]] = row
                    bar.update(1)
        bar.close()
        order = {run_id(sweep, run): k for k, run in enumerate(sweep.runs())}
        table = pd.DataFrame(
            sorted((r for r in done.values() if r["run_id"] in order), key=lambda r: order[r["run_id"]])
        )
        paths = write_tables(table, list(sweep.grid), out_dir)
    return SweepReport(
        table, len(pending), len(sweep.runs()) - len(pending), time.perf_counter() - started, paths, skipped
    )


class SweepLock:
    """An exclusive claim on a results folder (``sweep.lock``, created with O_EXCL, holding the
    process id and host): a second sweep on the same folder stops with a message naming the
    process that holds it, instead of running every run again. A lock left by a process that is
    gone (on this host) is taken over."""

    NAME = "sweep.lock"

    def __init__(self, out_dir: Path):
        self.path = Path(out_dir) / self.NAME
        self.held = False

    def __enter__(self) -> SweepLock:
        for _ in range(2):
            try:
                handle = os.open(self.path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
            except FileExistsError:
                holder = self._holder()
                if holder is not None and self._alive(*holder):
                    pid, host = holder
                    message = (
                        f"{self.path.parent}: another sweep (process {pid} on {host}) is writing to this "
                        f"folder; wait for it to finish, or remove {self.path} if it is gone"
                    )
                    raise ConfigError(message) from None
                self.path.unlink(missing_ok=True)  # stale: its process is gone
                continue
            with os.fdopen(handle, "w") as lock:
                lock.write(f"{os.getpid()} {socket.gethostname()}\n")
            self.held = True
            return self
        raise ConfigError(f"{self.path}: could not take the sweep lock")

    def __exit__(self, *exc_info) -> None:
        if self.held:
            self.path.unlink(missing_ok=True)
            self.held = False

    def _holder(self) -> tuple[int, str] | None:
        try:
            pid, host = self.path.read_text().split()[:2]
            return int(pid), host
        except (OSError, ValueError):
            return None  # unreadable or half-written: treated as stale

    @staticmethod
    def _alive(pid: int, host: str) -> bool:
        if host != socket.gethostname():
            return True  # another machine's process: cannot tell, so respect its lock
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return False
        except PermissionError:
            return True
        return True


def _execute(sweep: Sweep, runs: list[dict], maps_folder: str, workers: int | None, scheduler: str | None):
    """Yield rows as runs finish, on local processes or a Dask cluster.

    Locally, on one set of worker processes: the distinct simulations are run first (in parallel),
    then the distinct batch optima of those logs (``optimum_key``), then the filter runs on the logs
    and optima they wrote, the most particles first (the longest runs do not trail at the end, one
    worker busy and the others idle). A Dask cluster's workers may not share a disk: there each run
    simulates its own log and computes its own optimum."""
    if not runs:
        return
    if scheduler:
        yield from _on_dask(scheduler, execute_run, [(sweep, run, maps_folder) for run in runs])
        return
    runs = sorted(runs, key=lambda run: -configure(sweep, run["settings"])[1].fastslam.NPARTICLES)
    with tempfile.TemporaryDirectory() as logs, _local_pool(workers) as pool:
        distinct = list({simulation_key(sweep, run): run for run in runs}.values())
        for _ in _locally(pool, simulate_run, [(sweep, run, logs) for run in distinct]):
            pass
        optima = list({optimum_key(sweep, run): run for run in runs}.values())
        for _ in _locally(pool, optimum_run, [(sweep, run, logs) for run in optima]):
            pass
        yield from _locally(pool, execute_run, [(sweep, run, maps_folder, logs) for run in runs])


#: What a run loads on first use (``metrics.map_error``'s scipy.optimize): loaded once here before the
#: worker processes fork from this one, instead of once in each of them.
WORKER_MODULES = ("scipy.optimize",)


@contextlib.contextmanager
def _local_pool(workers: int | None):
    """``workers`` local processes (default: one per core), forked once for every phase of a sweep;
    None for one worker (the runs go in this process).

    The workers end with this process (``ends_with_this_process``). Left by an exception (an error,
    Ctrl-C, ``Interrupted`` by SIGTERM, the generator of rows closed early), the pool's workers are
    terminated at once: ``ProcessPoolExecutor.shutdown`` would wait for the runs they are running,
    minutes for a large one, while their rows would not be written anyway."""
    if workers == 1:
        yield None
        return
    for name in WORKER_MODULES:
        importlib.import_module(name)
    pool = ProcessPoolExecutor(max_workers=workers, **ends_with_this_process())
    try:
        yield pool
    except BaseException:
        # The executor has no public way to end its workers before Python 3.14 (terminate_workers).
        for process in list((getattr(pool, "_processes", None) or {}).values()):
            process.terminate()
        raise
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


def _locally(pool: ProcessPoolExecutor | None, function, calls: list[tuple]):
    """``function(*arguments)`` for each of ``calls``, results yielded as they finish: on ``pool``'s
    processes, or in this process when ``pool`` is None."""
    if pool is None:
        for arguments in calls:
            yield function(*arguments)
        return
    for future in as_completed([pool.submit(function, *arguments) for arguments in calls]):
        yield future.result()


def _on_dask(scheduler: str, function, calls: list[tuple]):
    """``function(*arguments)`` for each of ``calls`` on the Dask cluster at ``scheduler``."""
    from distributed import Client
    from distributed import as_completed as dask_completed

    with Client(scheduler) as client:
        futures = [client.submit(function, *arguments, pure=False) for arguments in calls]
        for future in dask_completed(futures):
            yield future.result()


METRICS = [
    "ate_rmse",
    "ate_aligned_rmse",
    "reckoning_ate_rmse",
    "optimum_ratio",
    "optimum_aligned_ratio",
    "map_aligned_rmse",
    "rpe_trans_rmse",
    "median_nees",
    "landmarks",
    "slam_seconds",
    "seconds_per_record",
]


def summarise(table: pd.DataFrame, grid_keys: list[str], metrics: list[str] = METRICS) -> pd.DataFrame:
    """Mean and 95 % confidence half-width (Student's t over the seeds) of each metric per grid cell.
    The t quantile is ``scipy.special.stdtrit`` (what ``scipy.stats.t.ppf`` computes): importing
    scipy.stats took 0.3-0.8 s, at the end of a sweep after its parallel part."""
    from scipy.special import stdtrit

    groups = table.groupby(grid_keys, dropna=False) if grid_keys else [((), table)]
    rows = []
    for key, group in groups:
        key = key if isinstance(key, tuple) else (key,)
        row = dict(zip(grid_keys, key))
        row["runs"] = len(group)
        for metric in metrics:
            # A metric absent from older tables: no values.
            values = group.get(metric, pd.Series(dtype=float)).dropna().to_numpy(dtype=float)
            mean = values.mean() if len(values) else math.nan
            half = (
                stdtrit(len(values) - 1, 0.975) * values.std(ddof=1) / math.sqrt(len(values))
                if len(values) > 1
                else math.nan
            )
            row[metric], row[f"{metric}_ci95"] = mean, half
        rows.append(row)
    return pd.DataFrame(rows)


def write_tables(table: pd.DataFrame, grid_keys: list[str], out_dir: Path) -> dict[str, Path]:
    """``results.csv`` and ``results.parquet`` (one row per run) and ``summary.md`` (mean +- 95 % CI per cell)."""
    paths = {"csv": out_dir / "results.csv", "parquet": out_dir / "results.parquet", "summary": out_dir / "summary.md"}
    with written(paths["csv"]) as temporary:  # each whole or not at all, an error naming it (a full disk)
        table.to_csv(temporary, index=False)
    with written(paths["parquet"]) as temporary:
        table.to_parquet(temporary, index=False)
    write_file(paths["summary"], summary_markdown(table, grid_keys))
    return paths


def summary_markdown(table: pd.DataFrame, grid_keys: list[str]) -> str:
    summary = summarise(table, grid_keys)
    shown = summary[grid_keys + ["runs"]].copy()
    for metric in METRICS:
        unit = " [m]" if metric.endswith("rmse") else " [s]" if "seconds" in metric else ""
        shown[metric + unit] = [
            f"{m:.4g} ± {h:.2g}" if not math.isnan(h) else f"{m:.4g}"
            for m, h in zip(summary[metric], summary[f"{metric}_ci95"])
        ]
    return (
        "Mean ± 95 % confidence half-width over the seeds, per grid cell.\n\n" + shown.to_markdown(index=False) + "\n"
    )
