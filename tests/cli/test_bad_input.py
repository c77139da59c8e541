"""Bad input never crashes (issue 19): every case a fuzz campaign and a new user found gives a clear
one-line message naming the option or the file (and line), or works; nothing recorded is lost.

``cli`` runs a command as ``mazeslam`` does (``mazeslam.cli.main.run``): an error of ``KNOWN_ERRORS``
becomes ``error: <message>``; anything else is a traceback, and fails the test.
"""

from __future__ import annotations

import gzip
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from cli_runs import cli
from conftest import PROJECT_ROOT

from mazeslam.core.config import ConfigError, InputError, from_mapping, load_toml, with_changes
from mazeslam.data.carmen import read_carmen
from mazeslam.fastslam.filter import FastSLAMParams
from mazeslam.pipeline import SlamConfig
from mazeslam.sim.simulator import SimulationConfig
from mazeslam.sweeps.runner import RESULTS, SweepLock, load_sweep, run_id, run_sweep

PROJECT = PROJECT_ROOT
MAZE = PROJECT / "configs" / "mazes" / "narrow.txt"


def refused(*args, expect: str | list[str]) -> str:
    """Run a command that must fail cleanly, with every piece of ``expect`` in its one message."""
    status, output = cli(*args)
    assert status != 0, output
    assert "Traceback" not in output
    for piece in [expect] if isinstance(expect, str) else expect:
        assert piece in output, output
    return output


@pytest.fixture(scope="module")
def small_log(tmp_path_factory) -> Path:
    """A 6-second simulated run in a small maze, with its sidecars."""
    from mazeslam import simulate

    out = tmp_path_factory.mktemp("small") / "run.log"
    simulate(out, maze=MAZE, seed=1, duration=6.0, progress=False)
    return out


@pytest.fixture
def unwritable(tmp_path) -> Path:
    """A folder that cannot be created (its parent is a file), whoever runs the tests (even root)."""
    blocker = tmp_path / "blocker"
    blocker.write_text("a file, not a folder\n")
    return blocker / "out"


# -- outputs checked before work ----------------------------------------------------------------


def test_slam_to_an_unwritable_folder_stops_before_the_filter(small_log, unwritable):
    started = time.perf_counter()
    refused("slam", small_log, "--out", unwritable, "--quiet", expect=[str(unwritable.parent), "output folder"])
    assert time.perf_counter() - started < 5


@pytest.mark.parametrize(
    "command",
    [
        lambda log, bad: ["simulate", "--out", bad / "x.log", "--duration", "1", "--quiet"],
        lambda log, bad: ["smooth", log, "--out", bad],
        lambda log, bad: ["calibrate", log, "--write", bad / "c.toml", "--quiet"],
        lambda log, bad: ["corners", log, "--json", bad / "c.json"],
        lambda log, bad: ["corners", log, "--plot", bad / "c.png"],
        lambda log, bad: ["corners", log, "--animate", bad / "c.gif"],
        lambda log, bad: ["import", "carmen", log, "--out", bad / "x.log"],
        lambda log, bad: ["record", "--sim", "--out", bad / "x.log"],
        lambda log, bad: ["demo", "--out", bad, "--quiet"],
    ],
    ids=[
        "simulate",
        "smooth",
        "calibrate",
        "corners-json",
        "corners-plot",
        "corners-animate",
        "import",
        "record",
        "demo",
    ],
)
def test_every_writing_command_probes_its_output_first(small_log, unwritable, command):
    refused(*command(small_log, unwritable), expect=str(unwritable.parent))


def test_sweep_to_an_unwritable_folder(tmp_path, unwritable):
    sweep = tmp_path / "s.toml"
    sweep.write_text('seeds = [0]\nduration = 1.0\n[grid]\n"slam.fastslam.NPARTICLES" = [5]\n')
    refused("sweep", sweep, "--out", unwritable, "--quiet", expect=str(unwritable.parent))


# -- simulate -------------------------------------------------------------------------------------


@pytest.mark.parametrize("value", ["inf", "nan", "-1", "1e300", "abc"])
def test_simulate_duration_must_be_a_sane_number(tmp_path, value):
    refused("simulate", "--out", tmp_path / "x.log", "--duration", value, expect="--duration")
    assert not (tmp_path / "x.log").exists()


def test_simulate_maze_that_is_a_folder(tmp_path):
    refused(
        "simulate", "--out", tmp_path / "x.log", "--maze", tmp_path, "--duration", "1", expect=[str(tmp_path), "folder"]
    )


def test_simulate_maze_that_is_a_course_log_says_so_briefly(tmp_path, small_log):
    output = refused(
        "simulate",
        "--out",
        tmp_path / "x.log",
        "--maze",
        small_log,
        "--duration",
        "1",
        expect=["not a maze file", f"{small_log}:1"],
    )
    assert len(output.strip().splitlines()[-1]) < 250


def test_simulate_maze_that_is_binary(tmp_path):
    maze = tmp_path / "maze.txt"
    maze.write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(range(256)))
    refused("simulate", "--out", tmp_path / "x.log", "--maze", maze, expect=[str(maze), "not UTF-8"])


@pytest.mark.parametrize(
    "option, value, expect",
    [
        ("--rows", "1000 --cols 1000", "cells"),
        ("--beams", "1000000000", "GB"),
        ("--seed", "-1", "--seed"),
        ("--seed", "1.5", "--seed"),
        ("--rows", "0", "--rows"),
    ],
)
def test_simulate_sizes_and_seeds(tmp_path, option, value, expect):
    refused("simulate", "--out", tmp_path / "x.log", option, *value.split(), "--duration", "1", expect=expect)


# -- readers: I/O, decoding, decompression ------------------------------------------------------


CARMEN = "PARAM robot_front_laser_max 50 nohost 0\n" + "".join(
    f"FLASER 5 1.0 2.0 3.0 2.0 1.0 {0.1 * k} 0 0 {0.1 * k} 0 0 {10 + k} nohost {10 + k}\n" for k in range(20)
)


def test_carmen_gzip_with_a_bad_crc(tmp_path):
    data = bytearray(gzip.compress(CARMEN.encode()))
    data[-8] ^= 0xFF  # the CRC32 of the trailer
    path = tmp_path / "bad.gz"
    path.write_bytes(bytes(data))
    refused("import", "carmen", path, "--out", tmp_path / "x.log", expect=[str(path), "CRC"])


def test_carmen_truncated_gzip(tmp_path):
    path = tmp_path / "cut.gz"
    path.write_bytes(gzip.compress(CARMEN.encode())[:-30])
    output = refused("import", "carmen", path, "--out", tmp_path / "x.log", expect=[str(path), "cut off"])
    assert "Aborted" not in output


def test_mrclam_truncated_gzip(tmp_path):
    dataset = tmp_path / "MRCLAM"
    dataset.mkdir()
    (dataset / "Robot1_Odometry.dat.gz").write_bytes(gzip.compress(b"0 0.1 0.0\n" * 50)[:-12])
    output = refused(
        "import",
        "mrclam",
        dataset,
        "--robot",
        "1",
        "--out",
        tmp_path / "x.log",
        expect=["Robot1_Odometry.dat.gz", "cut off"],
    )
    assert "Aborted" not in output


@pytest.mark.parametrize(
    "command",
    [
        lambda path, tmp: ["import", "carmen", path, "--out", tmp / "x.log"],
        lambda path, tmp: ["info", path],
        lambda path, tmp: ["slam", path, "--out", tmp / "s", "--quiet"],
        lambda path, tmp: ["corners", path],
    ],
    ids=["carmen", "info", "slam", "corners"],
)
def test_non_utf8_input_names_the_file_and_line(tmp_path, command):
    path = tmp_path / "binary.log"
    path.write_bytes(b"0.0 0 0.1 0.0\n" + b"\x89PNG\x00\xff\xfe\n")
    refused(*command(path, tmp_path), expect=[f"{path}:2", "not UTF-8"])


def test_sidecars_that_are_not_sidecars(tmp_path, small_log):
    log = tmp_path / "run.log"
    log.write_bytes(small_log.read_bytes())
    (tmp_path / "run.map.json").write_text("[1, 2, 3]")
    refused("info", log, expect=["run.map.json", "JSON object"])
    (tmp_path / "run.map.json").write_bytes(b"\xff\xfe{")
    refused("info", log, expect=["run.map.json", "not UTF-8"])
    (tmp_path / "run.map.json").unlink()
    (tmp_path / "run.truth.csv").write_text("t,x,y,theta\n1,2,3\n")
    refused("slam", log, "--out", tmp_path / "s", "--quiet", expect="run.truth.csv")


# -- settings: type, finiteness, range, size ------------------------------------------------------


@pytest.mark.parametrize(
    "section, line, expect",
    [
        ("fastslam", "NPARTICLES = 1.5", "[fastslam]: NPARTICLES = 1.5: must be an integer"),
        ("fastslam", "NPARTICLES = true", "[fastslam]: NPARTICLES = true: must be an integer"),
        ("fastslam", "NPARTICLES = 1180591620717411303424", "1180591620717411303424: must be an integer within"),
        ("fastslam", "NPARTICLES = 1000000000", "TB"),
        ("fastslam", "seed = 1.5", "[fastslam]: seed = 1.5: must be an integer"),
        ("fastslam", "seed = -1", "seed must be a non-negative integer"),
        ("fastslam", "sigmaTH = 1e300", "[fastslam]: sigmaTH = 1e+300: is out of range"),
        ("fastslam", "sigmaX = true", "[fastslam]: sigmaX = true: must be a number"),
        ("fastslam", 'sigmaX = "0.1"', "must be a number"),
        ("fastslam", "sigmaX = nan", "not nan"),
        ("scan_matching", 'enabled = "yes"', "[scan_matching]: enabled = 'yes': must be true or false"),
        ("sensor", "first_beam_angle = nan", "[sensor]: first_beam_angle = nan: must be a number, not nan"),
        ("sensor", "mount_x = inf", "must be finite"),
        ("evaluation", "match_radius = -1", "match_radius must be in (0, 100]"),
        ("scan_matching.correlative", "turn_step = inf", "turn_step = inf: must be finite"),
        ("corners", "max_range = inf", None),  # an infinite limit: no limit, accepted
        ("corners", "max_range = nan", "not nan"),
        ("corners", "covariance_scale = {corner = true}", "entry 'corner' (true) must be a number"),
        ("scan_matching", "correspondence_distances = [1.0, nan]", "item 2 (nan)"),
    ],
)
def test_bad_slam_config_values_name_file_section_key_value_and_reason(tmp_path, section, line, expect):
    path = tmp_path / "c.toml"
    path.write_text(f"[{section}]\n{line}\n")
    if expect is None:
        load_toml(SlamConfig, path)
        return
    with pytest.raises(ConfigError) as caught:
        load_toml(SlamConfig, path)
    assert str(caught.value).startswith(f"{path}"), caught.value
    assert expect in str(caught.value)


@pytest.mark.parametrize(
    "section, line, expect",
    [
        ("laser", "beams = 1000000000", "GB"),
        ("maze", "rows = 1000\ncols = 1000", "cells"),
        ("maze", "rows = 4.0", "must be an integer"),
        ("logger", "physics_rate = 1e9", "at most 10000 Hz"),
        ("", "max_duration = inf", "must be finite"),
        ("", "max_duration = 1e8", "days"),
        ("laser.geometry", "first_beam_angle = nan", "not nan"),
        ("robot", "mass = -inf", "must be finite"),
    ],
)
def test_bad_simulation_config_values(tmp_path, section, line, expect):
    path = tmp_path / "sim.toml"
    path.write_text((f"[{section}]\n" if section else "") + f"{line}\n")
    with pytest.raises(ConfigError, match=None) as caught:
        load_toml(SimulationConfig, path)
    assert expect in str(caught.value)
    refused("simulate", "--out", tmp_path / "x.log", "--config", path, expect=[str(path), expect])


def test_config_file_that_is_not_text(tmp_path):
    path = tmp_path / "c.toml"
    path.write_bytes(b"[fastslam]\nNPARTICLES = 5\n\xff\xfe")
    with pytest.raises(ConfigError, match=r"c.toml:3: not a text config file"):
        load_toml(SlamConfig, path)


def test_with_changes_checks_types_like_files():
    params = FastSLAMParams()
    for change, expect in [
        ({"NPARTICLES": 1.5}, "must be an integer"),
        ({"NPARTICLES": True}, "must be an integer"),
        ({"sigmaX": float("nan")}, "not nan"),
        ({"seed": 2**70}, "64 bits"),
        ({"nonsense": 1}, "unknown parameter"),
    ]:
        with pytest.raises(ConfigError, match=expect):
            with_changes(params, **change)
    assert with_changes(params, sigmaX=1).sigmaX == 1.0
    assert from_mapping(FastSLAMParams, {"sigmaR": 0}).sigmaR == 0.0


@pytest.mark.parametrize(
    "options, expect",
    [
        (["--particles", "1000000000"], ["--particles", "TB"]),
        (["--particles", "0"], "--particles"),
        (["--particles", "1.5"], "--particles"),
        (["--seed", "-1"], "--seed"),
        (["--first-beam-angle", "nan"], "--first-beam-angle"),
        (["--first-beam-angle", "inf"], "--first-beam-angle"),
        (["--mount-x", "inf"], "--mount-x"),
        (["--mount-x", "1e6"], "mount_x"),
        (["--beam-direction", "2"], "--beam-direction"),
    ],
)
def test_slam_options_name_the_option(small_log, tmp_path, options, expect):
    refused("slam", small_log, "--out", tmp_path / "s", "--quiet", *options, expect=expect)


@pytest.mark.parametrize(
    "options, expect",
    [
        (["--beams", "1000000000"], "--beams"),
        (["--scan-period", "nan"], "--scan-period"),
        (["--odometry-rate", "inf"], "--odometry-rate"),
        (["--duration", "inf"], "--duration"),
        (["--seed", "-1"], "--seed"),
        (["--height", "0"], "--height"),
        (["--center", "nan", "1"], "--center"),
    ],
)
def test_record_options_name_the_option(tmp_path, options, expect):
    refused("record", "--sim", "--out", tmp_path / "x.log", *options, expect=expect)


def test_info_mount_x_and_absurd_odometry(tmp_path, small_log):
    refused("info", small_log, "--detect-beams", "--mount-x", "inf", expect="--mount-x")
    log = tmp_path / "absurd.log"
    lines = small_log.read_text().splitlines()
    odometry = next(k for k, line in enumerate(lines) if line.split()[1] == "0")
    parts = lines[odometry].split()
    parts[2] = "1e308"
    lines[odometry] = " ".join(parts)
    log.write_text("\n".join(lines) + "\n")
    output = refused("info", log, expect=[f"{log}:{odometry + 1}", "implausibly large"])
    assert "inf m" not in output
    status, output = cli("info", log, "--lenient")
    assert status == 0 and "inf m" not in output and f"skipped line {odometry + 1}" in output


# -- sweeps -------------------------------------------------------------------------------------------


def _sweep_with_finished_runs(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text('name = "t"\nseeds = [0, 1]\nduration = 2.0\n[grid]\n"slam.fastslam.NPARTICLES" = [5]\n')
    sweep = load_sweep(path)
    out = tmp_path / "out"
    out.mkdir()
    rows = [
        {"run_id": run_id(sweep, run), "seed": run["seed"], "slam.fastslam.NPARTICLES": 5, "ate_rmse": 0.01}
        for run in sweep.runs()
    ]
    return path, sweep, out, rows


def test_sweep_results_lines_that_are_not_results_are_reported_and_skipped(tmp_path):
    path, sweep, out, rows = _sweep_with_finished_runs(tmp_path)
    junk = ["{}", "123", "[1, 2]", '{"run_id": 5}', "null", "not json", '"text"']
    (out / RESULTS).write_text("\n".join([json.dumps(rows[0]), *junk, json.dumps(rows[1])]) + "\n")
    result = run_sweep(sweep, out, workers=1, progress=False)
    assert result.ran == 0 and len(result.table) == 2
    assert len(result.skipped) == len(junk)
    assert all(f"{RESULTS}:" in problem for problem in result.skipped)
    status, output = cli("sweep", path, "--out", out, "--quiet")
    assert status == 0, output
    assert "warning:" in output and "not a result" in output


def test_two_sweeps_on_one_folder(tmp_path):
    path, sweep, out, rows = _sweep_with_finished_runs(tmp_path)
    (out / RESULTS).write_text("".join(json.dumps(row) + "\n" for row in rows))
    with SweepLock(out):
        with pytest.raises(ConfigError, match=f"another sweep \\(process {os.getpid()} on "):
            run_sweep(sweep, out, workers=1, progress=False)
        refused("sweep", path, "--out", out, "--quiet", expect=[f"process {os.getpid()}", "another sweep"])
    assert not (out / SweepLock.NAME).exists()
    # A lock whose process is gone is stale: taken over.
    gone = subprocess.Popen([sys.executable, "-c", "pass"])
    gone.wait()
    import socket

    (out / SweepLock.NAME).write_text(f"{gone.pid} {socket.gethostname()}\n")
    assert run_sweep(sweep, out, workers=1, progress=False).ran == 0
    assert not (out / SweepLock.NAME).exists()


def test_sweep_file_values_are_checked(tmp_path):
    for text, expect in [
        ('seeds = [true]\n[grid]\n"slam.fastslam.NPARTICLES" = [5]\n', "seeds"),
        ('seeds = [0]\nduration = inf\n[grid]\n"slam.fastslam.NPARTICLES" = [5]\n', "duration"),
        ('seeds = [0]\n[grid]\n"slam.fastslam.NPARTICLES" = [1.5]\n', "must be an integer"),
        ('seeds = [0]\n[grid]\n"slam.fastslam.sigmaX" = [nan]\n', "not nan"),
        ('seeds = [0]\nname = 5\n[grid]\n"slam.fastslam.NPARTICLES" = [5]\n', "name"),
    ]:
        path = tmp_path / "s.toml"
        path.write_text(text)
        with pytest.raises(ConfigError, match=expect):
            load_sweep(path)


# -- the recorder: nothing recorded is lost ----------------------------------------------------------


def _start_recording(tmp_path) -> tuple[subprocess.Popen, Path]:
    script = tmp_path / "drive.txt"
    script.write_text("100000 0.02 0.3\n")
    out = tmp_path / "rec.log"
    process = subprocess.Popen(
        [
            sys.executable,
            "-c",
            "from mazeslam.cli.main import run; run()",
            "record",
            "--sim",
            "--maze",
            str(MAZE),
            "--beams",
            "36",
            "--script",
            str(script),
            "--out",
            str(out),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        if out.exists() and out.read_text().count("\n") > 30:
            return process, out
        time.sleep(0.1)
    process.kill()
    raise AssertionError(f"the recording did not start: {process.communicate()}")


@pytest.mark.parametrize("kill", [signal.SIGTERM, signal.SIGINT, signal.SIGKILL], ids=["TERM", "INT", "KILL"])
def test_killed_recording_keeps_its_sidecars(tmp_path, kill):
    from mazeslam.data import sidecars
    from mazeslam.data.loaded_run import load_run

    process, out = _start_recording(tmp_path)
    assert sidecars.map_path(out).exists() and sidecars.truth_path(out).exists()  # written from the start
    process.send_signal(kill)
    stdout, stderr = process.communicate(timeout=30)
    if kill != signal.SIGKILL:
        assert process.returncode == 0, stderr
        assert f"stopped by {kill.name}" in stdout
        assert "Traceback" not in stderr
    run = load_run(out, strict=kill != signal.SIGKILL)
    assert run.truth is not None and len(run.truth) == len(run.log)
    assert run.geometry_origin.startswith("sidecar")
    assert np.isfinite(run.truth).all()


def test_read_carmen_error_types(tmp_path):
    path = tmp_path / "folder.gz"
    path.mkdir()
    with pytest.raises(InputError, match="is a folder"):
        read_carmen(path)
