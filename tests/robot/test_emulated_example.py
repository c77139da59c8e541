"""examples/emulated_epuck.py: the emulated e-puck usable without copying from the tests (issue 35)."""

import runpy

from conftest import PROJECT_ROOT

from mazeslam.data import log, sidecars


def test_the_example_records_a_course_log_from_the_emulated_e_puck(tmp_path):
    example = runpy.run_path(str(PROJECT_ROOT / "examples" / "emulated_epuck.py"))
    records = example["record"](tmp_path / "emulated.log", beams=60)
    course_log = log.read(tmp_path / "emulated.log")
    assert len(course_log) == records and course_log.n_beams == 60
    # The script drives 3 s + 2 s at 4 cm/s: the odometry travelled about 0.2 m.
    assert abs(course_log.odometry[:, 0].sum() - 0.2) < 0.03
    world = sidecars.read_map(sidecars.map_path(tmp_path / "emulated.log"))
    assert world["source"].startswith("mazeslam record (real robot")
