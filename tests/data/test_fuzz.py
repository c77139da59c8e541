"""The project's own fuzz tests (issue 19 item 7): property-based tests of the course-log reader,
the CARMEN reader and the config loader, and a seeded corpus of mutated logs and configs.

Every input either reads, giving only finite numbers, or is refused with one of the project's
clear errors (``mazeslam.cli.main.KNOWN_ERRORS``: never a traceback). Deterministic: hypothesis is
derandomized and the corpus is drawn from fixed seeds.
"""

from __future__ import annotations

import gzip
import math
import traceback

import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mazeslam.cli.main import KNOWN_ERRORS, main
from mazeslam.core.config import ConfigError, from_mapping, load_toml, to_mapping
from mazeslam.data import log
from mazeslam.data.carmen import read_carmen
from mazeslam.pipeline import SlamConfig
from mazeslam.sim.simulator import SimulationConfig

FUZZ = settings(
    max_examples=150,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)

#: Tokens a corrupted file holds: numbers out of range, non-numbers, odd spellings.
WEIRD = [
    "nan",
    "-nan",
    "inf",
    "-inf",
    "1e308",
    "-1e308",
    "1e999",
    "0",
    "-0",
    "-1",
    "1.5",
    "2",
    "3",
    "18446744073709551617",
    "0x10",
    "1_000",
    "",
    "abc",
    "NaN",
    "+inf",
    "1e-320",
    "é",
    "\x00",
    "#",
    "%",
    ",",
    "1,2",
    "9" * 400,
]


def _base_log(beams: int = 6, records: int = 24, landmarks: bool = False) -> str:
    """A small valid log: odometry, and scans or (``landmarks``) landmark observations (a log holds
    one kind or the other)."""
    rng = np.random.default_rng(0)
    lines = ["# a small course log"]
    for k in range(records):
        t = 0.2 * k
        if k % 3 == 2 and not landmarks:
            lines.append(f"{t:.6f} 1 " + " ".join(f"{r:.6f}" for r in rng.uniform(0, 0.5, beams)))
        elif k % 3 == 2 or k % 7 == 5 and landmarks:
            lines.append(f"{t:.6f} 2 {k % 4} 0.3 0.5 " + " ".join(["-1"] * (beams - 3)))
        else:
            lines.append(
                f"{t:.6f} 0 {rng.uniform(0, 0.01):.6f} {rng.uniform(-0.1, 0.1):.6f} " + " ".join(["-1"] * (beams - 2))
            )
    return "\n".join(lines) + "\n"


BASE_LOG = _base_log()
LANDMARK_LOG = _base_log(landmarks=True)


def _assert_finite_log(course_log: log.CourseLog) -> None:
    assert np.isfinite(course_log.times).all() and np.isfinite(course_log.values).all()
    for key, value in log.summary(course_log).items():
        if isinstance(value, float):
            assert math.isfinite(value), (key, value)


def _parse_or_refuse(text: str, strict: bool) -> None:
    try:
        course_log = log.parse(text, "<fuzz>", strict=strict)
    except log.LogFormatError:
        return
    _assert_finite_log(course_log)


# -- property-based -------------------------------------------------------------------------------


@FUZZ
@given(
    lines=st.lists(
        st.lists(st.one_of(st.sampled_from(WEIRD), st.floats(), st.integers().map(str)), min_size=0, max_size=9).map(
            lambda parts: " ".join(map(str, parts))
        ),
        min_size=0,
        max_size=12,
    ),
    strict=st.booleans(),
)
def test_log_reader_reads_or_refuses_any_lines(lines, strict):
    _parse_or_refuse("\n".join(lines), strict)


@FUZZ
@given(text=st.text(max_size=400), strict=st.booleans())
def test_log_reader_reads_or_refuses_any_text(text, strict):
    _parse_or_refuse(text, strict)


@FUZZ
@given(data=st.data())
def test_log_reader_on_mutated_valid_logs(data):
    lines = data.draw(st.sampled_from([BASE_LOG, LANDMARK_LOG])).splitlines()
    for _ in range(data.draw(st.integers(1, 4))):
        row = data.draw(st.integers(0, len(lines) - 1))
        parts = lines[row].split()
        if parts:
            column = data.draw(st.integers(0, len(parts) - 1))
            parts[column] = data.draw(st.sampled_from(WEIRD))
        lines[row] = " ".join(parts)
    _parse_or_refuse("\n".join(lines), data.draw(st.booleans()))


CARMEN_TOKENS = st.sampled_from(["FLASER", "ODOM", "PARAM", "NEFF", "robot_front_laser_max", "nohost", *WEIRD])


@FUZZ
@given(
    lines=st.lists(
        st.lists(st.one_of(CARMEN_TOKENS, st.floats().map(str), st.integers(-5, 400).map(str)), max_size=14).map(
            " ".join
        ),
        max_size=10,
    ),
    gzipped=st.booleans(),
    cut=st.integers(0, 40),
)
def test_carmen_reader_reads_or_refuses(tmp_path_factory, lines, gzipped, cut):
    data = ("\n".join(lines) + "\n").encode("utf-8", errors="surrogatepass")
    if gzipped:
        data = gzip.compress(data)
        data = data[: len(data) - cut] if cut < len(data) else data
    path = tmp_path_factory.mktemp("carmen") / "fuzz.log"
    path.write_bytes(data)
    try:
        carmen = read_carmen(path)
    except KNOWN_ERRORS:
        return
    for array in (carmen.scan_times, carmen.ranges, carmen.scan_poses, carmen.odometry_poses, carmen.odometry_times):
        assert np.isfinite(array).all()
    assert math.isfinite(carmen.max_range)


SETTING_VALUES = st.recursive(
    st.one_of(st.none(), st.booleans(), st.integers(), st.floats(), st.text(max_size=8)),
    lambda children: st.one_of(
        st.lists(children, max_size=3), st.dictionaries(st.text(max_size=6), children, max_size=3)
    ),
    max_leaves=6,
)


def _section_strategy(params) -> st.SearchStrategy:
    """Mappings over a dataclass's own keys (and a few unknown ones), with any values."""
    names = list(to_mapping(params))
    return st.dictionaries(st.sampled_from(names + ["unknown"]), SETTING_VALUES, max_size=4)


def _assert_no_nan(mapping) -> None:
    if isinstance(mapping, dict):
        for value in mapping.values():
            _assert_no_nan(value)
    elif isinstance(mapping, (list, tuple)):
        for value in mapping:
            _assert_no_nan(value)
    elif isinstance(mapping, float):
        assert not math.isnan(mapping) and mapping != -math.inf


@FUZZ
@given(
    sections=st.fixed_dictionaries(
        {},
        optional={
            "fastslam": _section_strategy(SlamConfig().fastslam),
            "corners": _section_strategy(SlamConfig().corners),
            "sensor": _section_strategy(SlamConfig().sensor),
            "scan_matching": _section_strategy(SlamConfig().scan_matching),
            "evaluation": _section_strategy(SlamConfig().evaluation),
            "odometry": _section_strategy(SlamConfig().odometry),
        },
    )
)
def test_config_loader_accepts_or_refuses_any_values(sections):
    try:
        config = from_mapping(SlamConfig, sections, "fuzz.toml")
    except ConfigError:
        return
    _assert_no_nan(to_mapping(config))


@FUZZ
@given(
    sections=st.fixed_dictionaries(
        {},
        optional={
            name: _section_strategy(getattr(SimulationConfig(), name))
            for name in ("robot", "laser", "odometry", "logger", "drive", "maze")
        },
    )
)
def test_simulation_config_loader_accepts_or_refuses_any_values(sections):
    try:
        config = from_mapping(SimulationConfig, sections, "fuzz.toml")
    except ConfigError:
        return
    _assert_no_nan(to_mapping(config))


# -- the seeded corpus ---------------------------------------------------------------------------------


def mutate_text(text: str, rng: np.random.Generator) -> str:
    """One to four random corruptions of ``text``: a token replaced, a line dropped, duplicated or
    swapped, a cut, bytes flipped, a long line."""
    lines = text.splitlines()
    for _ in range(int(rng.integers(1, 5))):
        kind = int(rng.integers(0, 8))
        row = int(rng.integers(0, len(lines))) if lines else 0
        if not lines:
            lines = [str(rng.choice(WEIRD))]
        elif kind <= 2:
            parts = lines[row].split()
            if parts:
                parts[int(rng.integers(0, len(parts)))] = str(rng.choice(WEIRD))
            lines[row] = " ".join(parts)
        elif kind == 3:
            del lines[row]
        elif kind == 4:
            lines.insert(row, lines[row])
        elif kind == 5:
            other = int(rng.integers(0, len(lines)))
            lines[row], lines[other] = lines[other], lines[row]
        elif kind == 6:
            cut = "\n".join(lines)
            lines = cut[: int(rng.integers(0, len(cut) + 1))].splitlines()
        else:
            lines[row] = lines[row] + " " + " ".join(["1"] * int(rng.integers(1, 400)))
    return "\n".join(lines) + ("\n" if rng.random() < 0.9 else "")


LOG_CORPUS = 1200
CLI_EVERY = 10  # every 10th mutated log also goes through `mazeslam info` (and --lenient)


def test_mutated_log_corpus(tmp_path):
    rng = np.random.default_rng(19)
    refused = 0
    for k in range(LOG_CORPUS):
        text = mutate_text(LANDMARK_LOG if k % 4 == 3 else BASE_LOG, rng)
        data = text.encode()
        if rng.random() < 0.05:  # binary garbage or a gzip stream, whole or cut
            data = (
                bytes(rng.integers(0, 256, 40, dtype=np.uint8)) + data
                if rng.random() < 0.5
                else gzip.compress(data)[: int(rng.integers(10, 200))]
            )
        path = tmp_path / f"m{k}.log"
        path.write_bytes(data)
        for strict in (True, False):
            try:
                _assert_finite_log(log.read(path, strict=strict))
            except KNOWN_ERRORS:
                refused += 1
        if k % CLI_EVERY == 0:
            for extra in ([], ["--lenient"]):
                result = CliRunner().invoke(main, ["info", str(path), *extra])
                error = result.exception
                if error is not None and not isinstance(error, SystemExit):
                    assert isinstance(error, KNOWN_ERRORS), "".join(traceback.format_exception(error))
                assert "Traceback" not in result.output
                assert not any(word in result.output.split() for word in ("inf", "nan", "-inf")), result.output
    assert 0 < refused < 2 * LOG_CORPUS  # some mutants are still valid logs, most are not


CONFIG_CORPUS = 150
CONFIGS = {
    "fastslam": (
        "[fastslam]\nNPARTICLES = 100\nsigmaX = 0.002\nsigmaTH = 0.012\nseed = 0\nversion = 2\n"
        'association = "unknown"\ninflation = 2.0\n[corners]\nmin_range = 0.02\nmax_range = 0.5\n'
        'mode = "corners"\ncovariance_scale = {corner = 0.85, wall_end = 5.5}\n[corners.lines]\n'
        "min_points = 5\nsplit_threshold = 0.012\n[sensor]\nfirst_beam_angle = -3.14\nmount_x = 0.0\n"
        "[scan_matching]\nenabled = false\ncorrespondence_distances = [1.0, 0.5]\n"
        "[scan_matching.correlative]\nturn_step = 3.0\n[evaluation]\nmatch_radius = 0.05\n"
        "[odometry]\njump_tolerance = inf\n",
        SlamConfig,
    ),
    "simulation": (
        "max_duration = 600.0\n[laser]\nbeams = 90\nmax_range = 0.8\ndropout = 0.0\n"
        "[laser.geometry]\nfirst_beam_angle = 0.0\ndirection = 1\n[maze]\nrows = 3\ncols = 3\n"
        "[logger]\nscan_period = 0.75\nodometry_rate = 5.0\n[robot]\nmass = 0.2\n",
        SimulationConfig,
    ),
}
CONFIG_WEIRD = [
    "true",
    "false",
    '"yes"',
    "nan",
    "inf",
    "-inf",
    "1e300",
    "-1e300",
    "1180591620717411303424",
    "-1",
    "0",
    "1.5",
    "[]",
    "{}",
    '"x"',
    "1000000000",
    "[nan]",
    "{corner = true}",
    '"\\u0000"',
    # plausible values too, so that some mutants load and run
    "0.5",
    "0.05",
    "3",
    "10",
    "1",
    "0.01",
    "2",
]


def test_mutated_config_corpus(tmp_path):
    rng = np.random.default_rng(1919)
    loaded = 0
    for k in range(CONFIG_CORPUS):
        name = ("fastslam", "simulation")[k % 2]
        text, cls = CONFIGS[name]
        lines = text.splitlines()
        for _ in range(int(rng.integers(1, 4))):
            row = int(rng.integers(0, len(lines)))
            if "=" in lines[row] and rng.random() < 0.8:
                key = lines[row].split("=", 1)[0]
                lines[row] = f"{key}= {rng.choice(CONFIG_WEIRD)}"
            else:
                lines[row] = mutate_text(lines[row], rng).strip()
        path = tmp_path / f"c{k}.toml"
        path.write_text("\n".join(lines) + "\n")
        try:
            config = load_toml(cls, path)
        except ConfigError as error:
            assert str(error).startswith(str(path)), error
            continue
        loaded += 1
        _assert_no_nan(to_mapping(config))
        if k % 10 == 0:  # the command line too
            command = (
                ["simulate", "--out", str(tmp_path / "x" / f"{k}.log"), "--duration", "0.5", "--quiet"]
                if cls is SimulationConfig
                else ["info", str(tmp_path / "absent.log")]
            )
            result = CliRunner().invoke(main, [*command, "--config", str(path)] if cls is SimulationConfig else command)
            if result.exception is not None and not isinstance(result.exception, SystemExit):
                assert isinstance(result.exception, KNOWN_ERRORS), "".join(traceback.format_exception(result.exception))
    assert loaded > 0


@pytest.mark.parametrize("value", ["1e308", "-1e308", "1e9", "123456789012"])
def test_absurd_odometry_never_gives_infinite_travel(value):
    text = BASE_LOG.replace("0 0.00", f"0 {value} 0.00", 1)
    first = next(line for line in text.splitlines() if f" {value} " in line)
    text = text.replace(first, " ".join(first.split()[:2] + [value] + first.split()[3:]))
    _parse_or_refuse(text, strict=True)
    _parse_or_refuse(text, strict=False)
