"""The vectorised filter against the plain per-particle loop, on the same log and random draws."""

import dataclasses

import numpy as np
from reference_fastslam import LoopFastSLAM

from mazeslam.data import log
from mazeslam.data.loaded_run import load_run
from mazeslam.fastslam.filter import FastSLAM, FastSLAMParams
from mazeslam.features.corners import CornerExtractor


def test_vectorised_update_equals_the_per_particle_loop(default_run):
    course_log = log.read(default_run.log_path)
    geometry = load_run(default_run.log_path).geometry
    extractor = CornerExtractor(geometry, course_log.width)
    params = FastSLAMParams(NPARTICLES=12, seed=4, version=1)  # the loop is FastSLAM 1.0
    fast, loop = FastSLAM(params), LoopFastSLAM(params)
    reports = []
    for record in list(course_log.records())[:300]:
        if isinstance(record, log.OdometryRecord):
            fast.predict(record.distance, record.turn)
            loop.predict(record.distance, record.turn)  # same seed: the same noise draws
        else:
            features = extractor.extract(record.ranges)
            z, covariances = features.observation_array(), features.observation_covariances()
            a, b = fast.update(z, covariances), loop.update(z, covariances)
            reports.append((a, b))
        np.testing.assert_allclose(fast.poses, loop.poses, atol=1e-12)
        np.testing.assert_allclose(fast.log_weights, loop.log_weights, atol=1e-8)
        np.testing.assert_array_equal(fast.exists, loop.exists)
        np.testing.assert_allclose(fast.means[fast.exists], loop.means[loop.exists], atol=1e-10)
        np.testing.assert_allclose(fast.covariances[fast.exists], loop.covariances[loop.exists], atol=1e-12)
    for a, b in reports:
        assert dataclasses.astuple(a)[:6] == dataclasses.astuple(b)[:6]
    assert sum(a.resampled for a, _ in reports) > 5  # the comparison went through resamplings too
    assert sum(a.matched for a, _ in reports) > 100
