"""``write_run``: from Python, every file ``mazeslam slam`` writes, for both filters."""

import numpy as np
import pytest
from click.testing import CliRunner

from mazeslam.cli.main import main
from mazeslam.core.config import with_settings
from mazeslam.data import sidecars
from mazeslam.data.loaded_run import load_run
from mazeslam.pipeline import SlamConfig, run_slam
from mazeslam.viz.run_files import write_run


@pytest.fixture(scope="module")
def short_log(tmp_path_factory):
    from mazeslam import simulate

    return simulate(tmp_path_factory.mktemp("files") / "short.log", seed=2, duration=15.0, progress=False).log_path


@pytest.mark.parametrize("kind", ["landmarks", "grid"])
def test_python_writes_the_files_the_command_writes(short_log, tmp_path, kind):
    config = with_settings(SlamConfig(), {"map.kind": kind, "fastslam.NPARTICLES": 5, "grid.particles": 3})
    run = load_run(short_log)
    result = run_slam(run, config, progress=False, snapshot_every=5)
    paths = write_run(tmp_path / "api", run, config, result, animate=True)
    options = ["--map", kind, "--particles", "5" if kind == "landmarks" else "3", "--animate", "--quiet"]
    done = CliRunner().invoke(main, ["slam", str(short_log), *options, "--out", str(tmp_path / "cli")])
    assert done.exit_code == 0, done.output
    written = {path.name for path in (tmp_path / "api").iterdir()}
    assert written == {path.name for path in (tmp_path / "cli").iterdir()} - {"beam_convention.json"}
    assert {p.name for p in paths.values()} <= written and "slam.gif" in written and "slam.png" in written
    assert ("landmarks.csv" in written) is (kind == "landmarks")
    times, poses, _ = sidecars.read_trajectory(tmp_path / "api" / "trajectory.csv")
    np.testing.assert_allclose(poses, result.mean_poses, atol=1e-6)  # the file holds the run's mean path
