"""Edge-sized and odd-but-plausible logs (issue 36) of every kind: one record, one scan, only
odometry, only scans, huge jumps, times going back or repeating, mixed record kinds, blind scans,
no motion. Each gives a result with only finite numbers or is refused with one of the project's
clear errors, one line; never a traceback, never a warning.

Each edit changes the records of a tiny log (``fuzz_logs``) and its truth alike. A property-based
test draws whole small logs too (hypothesis, derandomized like tests/data/test_fuzz.py).

Cases: 18 edits x 4 kinds x 2 configs (the defaults, the kind's own) x 2 map kinds x 2
associations = 576; 400 drawn logs; 976 in all.
"""

from __future__ import annotations

import numpy as np
import pytest
from fuzz_logs import ASSOCIATIONS, LOG_KINDS, MAP_KINDS, OWN_CONFIG, Records, build, config_for, edited, slam_outcome
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mazeslam.data.log import LANDMARK, ODOMETRY, SCAN

FUZZ = settings(
    max_examples=400,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)


def _first(records: Records, mask: np.ndarray) -> Records:
    """The first of the records ``mask`` (R,) selects, alone."""
    return records.take(np.flatnonzero(mask)[:1])


def _observations(records: Records) -> np.ndarray:
    """Mask (R,) of the records that observe: scans or landmark observations."""
    return records.flags != ODOMETRY


def _with_odometry(records: Records, distance: float | None = None, turn: float | None = None) -> Records:
    """The records with the first odometry record's dX (m) or dTheta (rad) replaced."""
    values = records.values.copy()
    row = np.flatnonzero(records.flags == ODOMETRY)[0]
    if distance is not None:
        values[row, 0] = distance
    if turn is not None:
        values[row, 1] = turn
    return Records(records.times, records.flags, values, records.truth)


def _with_times(records: Records, times: np.ndarray) -> Records:
    return Records(times, records.flags, records.values, records.truth)


def _swapped_kind(records: Records) -> Records:
    """One odometry record turned into an observation of the other kind: a landmark observation
    in a log of scans, a scan in a log of landmark observations (mixed record kinds)."""
    flags, values = records.flags.copy(), records.values.copy()
    row = np.flatnonzero(flags == ODOMETRY)[-1]
    if (flags == SCAN).any():
        flags[row] = LANDMARK
        values[row, :3] = [0, 0.3, 0.5]
    else:
        flags[row] = SCAN
        values[row] = 0.5
    return Records(records.times, flags, values, records.truth)


def _scans_set(records: Records, ranges) -> Records:
    """Every scan's ranges (m) set to ``ranges`` (a landmark log: every observation's range)."""
    values = records.values.copy()
    if (records.flags == SCAN).any():
        values[records.flags == SCAN] = ranges
    else:
        values[records.flags == LANDMARK, 1] = max(float(ranges), 1e-3)
    return Records(records.times, records.flags, values, records.truth)


def _repeated(records: Records) -> Records:
    """Every record twice, one after the other, at the same time (a logger writing each line twice)."""
    return records.take(np.repeat(np.arange(len(records.times)), 2))


def _scaled_odometry(records: Records, scale: float) -> Records:
    """Every odometry record's dX and dTheta times ``scale``."""
    values = records.values.copy()
    values[records.flags == ODOMETRY, :2] *= scale
    return Records(records.times, records.flags, values, records.truth)


EDITS = {
    "one-record": lambda r: r.take([0]),
    "one-scan": lambda r: _first(r, _observations(r)),
    "one-odometry-one-scan": lambda r: r.take(
        [np.flatnonzero(~_observations(r))[0], np.flatnonzero(_observations(r))[0]]
    ),
    "only-odometry": lambda r: r.take(~_observations(r)),
    "only-scans": lambda r: r.take(_observations(r)),
    "jump-5km": lambda r: _with_odometry(r, distance=5000.0),
    "jump-1e6m": lambda r: _with_odometry(r, distance=-1e6),
    "turn-1e6rad": lambda r: _with_odometry(r, turn=1e6),
    "time-goes-back": lambda r: _with_times(r, np.r_[r.times[:-1], r.times[0] - 1.0]),
    "times-repeat": lambda r: _with_times(r, np.full_like(r.times, r.times[0])),
    "time-jump-a-day": lambda r: _with_times(r, r.times + np.r_[0.0, np.full(len(r.times) - 1, 86400.0)]),
    "records-twice": _repeated,
    "mixed-kinds": _swapped_kind,
    "blind-scans": lambda r: _scans_set(r, 0.0),
    "scans-at-1e6m": lambda r: _scans_set(r, 1e6),
    "no-motion": lambda r: _scaled_odometry(r, 0.0),
    "backwards": lambda r: _scaled_odometry(r, -1.0),
    "reversed-records": lambda r: _with_times(r.take(np.arange(len(r.times))[::-1]), r.times),
}


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    return tmp_path_factory.mktemp("edge_logs")


@pytest.mark.parametrize("association", ASSOCIATIONS)
@pytest.mark.parametrize("map_kind", MAP_KINDS)
@pytest.mark.parametrize("own_config", [False, True], ids=["defaults", "own-config"])
@pytest.mark.parametrize("kind", list(LOG_KINDS))
@pytest.mark.parametrize("edit", list(EDITS))
def test_edge_sized_logs_map_or_are_refused(folder, edit, kind, own_config, map_kind, association):
    source = build(kind, folder, 0)
    path = folder / f"{kind}-{edit}" / f"{kind}-{edit}.log"
    if not path.exists():
        edited(source, path, EDITS[edit])
    config = OWN_CONFIG[kind] if own_config else None
    outcome = slam_outcome(path, lambda: config_for(config, map_kind, association))
    # Known beforehand: the log's own rules (times never decrease; a log holds scans or landmark
    # observations, not both), and the grid filter maps scans only.
    if edit in ("time-goes-back", "mixed-kinds") or (map_kind == "grid" and edit in ("only-odometry", "one-record")):
        assert outcome == "refused"


# -- drawn logs ----------------------------------------------------------------------------------------

#: Odometry values (dX m, dTheta rad) a log may hold: none, small, large, absurd but finite.
MOTIONS = st.sampled_from([0.0, 1e-6, 0.005, -0.005, 0.05, 0.3, -1.0, 3.2, 100.0, -5000.0, 1e6])
#: Steps between timestamps (s): repeats, normal, a long pause.
TIME_STEPS = st.sampled_from([0.0, 0.0, 0.01, 0.2, 0.75, 3600.0])


@st.composite
def small_logs(draw) -> str:
    """A log of 1 to 8 records: odometry and scans of ``beams`` ranges (a pattern: none returned,
    a room, far, random), or odometry and landmark observations."""
    beams = draw(st.sampled_from([3, 8, 90, 360]))
    landmarks = draw(st.booleans())
    t, lines = draw(st.sampled_from([0.0, 0.073, 1.7e9])), []
    for _ in range(draw(st.integers(1, 8))):
        t += draw(TIME_STEPS)
        kind = draw(st.sampled_from([ODOMETRY, LANDMARK if landmarks else SCAN]))
        if kind == ODOMETRY:
            values = [draw(MOTIONS), draw(MOTIONS) / 10] + [-1] * (beams - 2)
        elif kind == LANDMARK:
            values = [draw(st.integers(-1, 3)), draw(st.sampled_from([0.05, 0.5, 3.0, 1e4])), draw(MOTIONS) / 10]
            values += [-1] * (beams - 3)
        else:
            values = _scan(draw, beams)
        lines.append(f"{t:.6f} {kind} " + " ".join(f"{v:g}" for v in values))
    return "\n".join(lines) + "\n"


def _scan(draw, beams: int) -> list[float]:
    """Ranges (m) of one scan: none returned, one distance, a square room seen from its centre, random."""
    pattern = draw(st.sampled_from(["none", "constant", "room", "random"]))
    if pattern == "none":
        return [0.0] * beams
    if pattern == "constant":
        return [draw(st.sampled_from([0.01, 0.3, 40.0]))] * beams
    angles = 2 * np.pi * np.arange(beams) / beams
    if pattern == "room":
        return list(0.2 / np.maximum(np.abs(np.cos(angles)), np.abs(np.sin(angles))))
    rng = np.random.default_rng(draw(st.integers(0, 2**16)))
    return list(np.round(rng.uniform(0.0, 0.5, beams), 3))


@FUZZ
@given(
    text=small_logs(),
    kind=st.sampled_from(["course", "simulated", "carmen", "mrclam"]),
    own_config=st.booleans(),
    map_kind=st.sampled_from(MAP_KINDS),
    association=st.sampled_from(ASSOCIATIONS),
)
def test_drawn_small_logs_map_or_are_refused(tmp_path_factory, text, kind, own_config, map_kind, association):
    path = tmp_path_factory.mktemp("drawn") / "drawn.log"
    path.write_text(text)
    config = OWN_CONFIG[kind] if own_config else None
    slam_outcome(path, lambda: config_for(config, map_kind, association))
