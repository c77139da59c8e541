"""A loaded run reads a log and its sidecars once, with the beam geometry it was recorded with."""

import numpy as np

from mazeslam.core.beams import EXERCISE_CONVENTION, SensorOverrides
from mazeslam.data import log, sidecars
from mazeslam.data.loaded_run import load_run


def test_a_simulated_run_has_its_truth_map_start_and_geometry(default_run):
    run = load_run(default_run.log_path)
    assert len(run.truth) == len(run.log)
    np.testing.assert_allclose(run.truth, sidecars.read_truth(default_run.truth_path)[1])
    world = sidecars.read_map(default_run.map_path)
    np.testing.assert_allclose(run.start_pose, world["start_pose"])
    np.testing.assert_allclose(run.true_corners, world["corners"])
    assert run.geometry == sidecars.beam_geometry(world["sensor"]) and run.geometry_from_sidecar


def test_a_bare_log_starts_at_the_origin_with_the_exercise_convention_and_overrides(tmp_path):
    path = tmp_path / "bare.log"
    path.write_text("0.0 0 0.01 0.0 -1 -1\n0.1 1 0.5 0.6 0.7 0.8\n0.2 0 0.5 0.0 -1 -1\n")
    run = load_run(path, SensorOverrides(first_beam_angle=0.0))
    assert run.truth is None and run.world is None and len(run.true_corners) == 0
    np.testing.assert_array_equal(run.start_pose, [0.0, 0.0, 0.0])
    assert run.geometry.first_beam_angle == 0.0 and run.geometry.direction == EXERCISE_CONVENTION.direction
    assert "overridden by first_beam_angle" in run.geometry_origin
    np.testing.assert_array_equal(run.glitches(jump_tolerance=0.1), [2])  # the 0.5 m odometry step
    assert isinstance(run.log, log.CourseLog)


def test_a_glitch_pair_becomes_its_sum_and_a_lone_glitch_no_motion(tmp_path):
    # As log1: a lone -0.119 m jump (a wheel counter off once), then a pair +0.0645 / -0.0575 m
    # (off and back one record later, a scan between them) whose sum, 7 mm, is the real motion.
    lines = ["0.2 0 0.005 0.01", "0.4 0 -0.119 -0.003", "0.6 0 0.006 0", "0.8 1 0.3 0.3"]
    lines += ["1.0 0 0.0645 0.8491", "1.1 1 0.3 0.3", "1.2 0 -0.0575 -0.8491", "1.4 0 0.004 0"]
    # Not pairs: two jumps whose sum is no small motion, and two jumps with a normal record between.
    lines += ["1.6 0 0.0645 0", "1.8 0 0.0645 0", "2.0 0 0.0645 0", "2.2 0 0.003 0", "2.4 0 -0.0575 0"]
    path = tmp_path / "glitches.log"
    path.write_text("\n".join(lines) + "\n")
    run = load_run(path)
    assert run.glitches(0.02).tolist() == [1, 4, 6, 8, 9, 10, 12]
    assert run.glitch_pairs(0.02) == [(4, 6)]
    summed = run.log_with_glitch_pairs_summed(0.02).increments
    expected = [0.005, 0.0, 0.006, 0.0, 0.0, 0.0, 0.007, 0.004, 0.0, 0.0, 0.0, 0.003, 0.0]
    np.testing.assert_allclose(summed[:, 0], expected, atol=1e-12)
    np.testing.assert_allclose(summed[[0, 6], 1], [0.01, 0.0], atol=1e-12)
    dropped = run.log_without_glitches(0.02).increments
    np.testing.assert_allclose(dropped[:, 0], [0.005, 0, 0.006, 0, 0, 0, 0, 0.004, 0, 0, 0, 0.003, 0], atol=1e-12)
    assert "line 2 (t 0.400 s, dX -0.1190 m" in run.glitch_line(0.02)
    assert "line 5 (t 1.000 s" in run.glitch_line(0.02, pairs_summed=True).split("summed")[0]
