"""Every log kind x every config x both map kinds x both associations (issue 36): each run gives a
result with only finite numbers or is refused with one of the project's clear errors, one line;
never a traceback, never a warning (warnings are errors in the tests).

The logs are tiny (``fuzz_logs``: 9 to 17 records of the exercise robot, the simulator, an
imported CARMEN log and an imported MRCLAM dataset), three seeds of each, so that a case takes
milliseconds. The bulk runs through the Python API (``run_slam``, as ``slam_on_file``); a sample
through the command line (``mazeslam slam``), which also writes every file and prints every line.

Cases: 4 kinds x 3 seeds x 8 configs (7 files and the defaults) x 2 map kinds x 2 associations
= 384 through the API; 4 kinds x 2 configs (the defaults, the kind's own) x 2 map kinds = 16
through the command line; 400 in all.

The fuzz suite of tests/fuzz/ (issue 36), 2106 cases: this module's 400; edge-sized and drawn logs
976 (test_edge_logs_fuzz.py); Gymnasium actions, seeds and reset options 707
(test_env_actions_fuzz.py); interrupts 6 (test_interrupts_fuzz.py); a full disk 11
(test_full_disk_fuzz.py); the reproducers of what it found 6 (test_found_by_fuzz.py).
"""

from __future__ import annotations

import re

import pytest
from cli_runs import cli
from conftest import PROJECT_ROOT
from fuzz_logs import ASSOCIATIONS, CONFIGS, LOG_KINDS, MAP_KINDS, OWN_CONFIG, build, config_for, slam_outcome

SEEDS = (0, 1, 2)
SIMULATOR_CONFIGS = {"simulation.toml", "simulation_course_robot.toml"}


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    return tmp_path_factory.mktemp("log_kinds")


def expected(kind: str, config: str | None, map_kind: str, association: str) -> str | None:
    """The outcome known beforehand, where it is: a simulator config is not a SLAM config; the grid
    filter maps scans, which an MRCLAM log has none of; a log with its own config and unknown
    association maps; known association on scans needs the truth's corners, which the course log
    lacks. None: either outcome is allowed."""
    if config in SIMULATOR_CONFIGS or (kind == "mrclam" and map_kind == "grid"):
        return "refused"
    if kind == "course" and map_kind == "landmarks" and association == "known":
        return "refused"
    if config == OWN_CONFIG[kind] and association == "unknown":
        return "result"
    return None


@pytest.mark.parametrize("association", ASSOCIATIONS)
@pytest.mark.parametrize("map_kind", MAP_KINDS)
@pytest.mark.parametrize("config", CONFIGS, ids=lambda name: name or "defaults")
@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("kind", list(LOG_KINDS))
def test_every_log_kind_config_map_and_association_maps_or_is_refused(
    folder, kind, seed, config, map_kind, association
):
    path = build(kind, folder, seed)
    outcome = slam_outcome(path, lambda: config_for(config, map_kind, association))
    assert outcome == (expected(kind, config, map_kind, association) or outcome)


NUMBERS_THAT_ARE_NOT = re.compile(r"(?<![\w.])-?(nan|inf)(?![\w])", re.IGNORECASE)


#: Every kind, with its own config or the one chosen for it, both map kinds. (The course log's map
#: with configs/course.toml has one landmark: the line of the nearest two was "nan m apart".)
CLI_CASES = [
    pytest.param(
        kind,
        own_config,
        map_kind,
        id=f"{kind}-{'own-config' if own_config else 'defaults'}-{map_kind}",
    )
    for kind in LOG_KINDS
    for own_config in (False, True)
    for map_kind in MAP_KINDS
]


@pytest.mark.parametrize("kind, own_config, map_kind", CLI_CASES)
def test_the_command_line_maps_every_kind_or_refuses_in_one_line(folder, tmp_path, kind, own_config, map_kind):
    path = build(kind, folder, 0)
    config = ["--config", PROJECT_ROOT / "configs" / OWN_CONFIG[kind]] if own_config else []
    status, output = cli("slam", path, *config, "--map", map_kind, "--out", tmp_path / "out", "--quiet")
    if status:
        # one error line, last, after at most the note of which config was chosen for the log
        lines = output.splitlines()
        assert lines[-1].startswith("error: ") and all(line.startswith("settings: ") for line in lines[:-1]), output
        assert not (tmp_path / "out").exists() or not list((tmp_path / "out").iterdir())
    else:
        assert (tmp_path / "out" / "trajectory.csv").exists()
    # The error table's NEES columns are NaN by design in the rows of other estimators.
    prose = [line for line in output.splitlines() if not line.startswith("|")]
    assert not [line for line in prose if NUMBERS_THAT_ARE_NOT.search(line)], output
    if (kind, own_config) in {("simulated", False), ("course", True), ("carmen", True)}:
        assert status == 0, output
