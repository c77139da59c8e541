"""Shared fixtures: paths to the real data beside the project, and small simulated runs."""

from pathlib import Path

import pytest

from mazeslam.filters.fastslam import FastSLAMParams

PROJECT_ROOT = Path(__file__).resolve().parents[1]
SHARED_DATA = PROJECT_ROOT.parent / "shared" / "data"
COURSE_LOG = SHARED_DATA / "course" / "log1.txt"
#: FastSLAM without motion noise, one particle, the plain likelihood and no resampling: the filter's
#: algebra on hand-made cases (sensor noise 1 cm and 0.01 rad; tests replace what they need).
EXACT = FastSLAMParams(
    NPARTICLES=1,
    sigmaX=0,
    sigmaTH=0,
    sigmaTH_drive=0,
    sigmaR=0.01,
    sigmaB=0.01,
    observation_scale=0.0,
    resample_threshold=0,
    inflation=1.0,
)


@pytest.fixture
def course_log_path() -> Path:
    if not COURSE_LOG.exists():
        pytest.skip(f"real course log not found at {COURSE_LOG} (the shared data folder is absent)")
    return COURSE_LOG


@pytest.fixture(scope="session")
def default_run(tmp_path_factory):
    """A simulated run on every default (random 4 x 4 maze, seed 0), made once per test session."""
    from mazeslam import simulate

    out = tmp_path_factory.mktemp("default_run") / "run.log"
    return simulate(out, seed=0, progress=False)
