"""Shared fixtures and checks: paths to the real data beside the project, small simulated runs, and the
scans of a simulated log re-cast against its truth and map."""

from pathlib import Path

import numpy as np
import pytest

from mazeslam.core.geometry import compose
from mazeslam.data import log, sidecars
from mazeslam.fastslam.filter import FastSLAMParams
from mazeslam.sim.laser import cast_rays

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


def assert_scans_match_truth_and_map(log_path):
    """Re-cast every logged scan from the true pose against the map sidecar's walls."""
    course_log = log.read(log_path)
    _, truth = sidecars.read_truth(sidecars.truth_path(log_path))
    world = sidecars.read_map(sidecars.map_path(log_path))
    sensor = world["sensor"]
    geometry = sidecars.beam_geometry(sensor)
    bearings = geometry.bearings(course_log.width)
    tolerance = 5 * sensor["range_noise_std"] + 1e-6
    assert len(truth) == len(course_log)
    for index in np.flatnonzero(course_log.is_scan):
        sensor_pose = compose(truth[index], [geometry.mount_x, geometry.mount_y, 0.0])
        expected = cast_rays(sensor_pose[:2], sensor_pose[2] + bearings, world["walls"], sensor["max_range"])
        logged = course_log.values[index]
        returned = logged > 0
        assert returned.mean() > 0.5
        np.testing.assert_allclose(logged[returned], expected[returned], atol=tolerance)
        # Without dropout a beam returns nothing only when its wall is (nearly) out of range.
        assert np.all(expected[~returned] > sensor["max_range"] - tolerance)
    return course_log, truth, world
