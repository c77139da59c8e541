"""Where ``slam`` and ``smooth`` write by default, and reruns that replace (never mix) their files."""

from pathlib import Path

import pytest
from click.testing import CliRunner

from mazeslam.cli.main import main
from mazeslam.cli.run_folders import SLAM_FILES, clear_outputs, default_out_dir


def invoke(*args):
    return CliRunner().invoke(main, [str(a) for a in args], catch_exceptions=False)


@pytest.fixture(scope="module")
def short_log(tmp_path_factory) -> Path:
    """A 6-second simulated run with its sidecars, in a 'data' folder of its own."""
    from mazeslam import simulate

    out = tmp_path_factory.mktemp("data") / "short.log"
    simulate(out, seed=1, duration=6.0, progress=False)
    return out


def test_default_out_dir_is_under_runs_by_log_name():
    assert default_out_dir("../shared/data/course/log1.txt", "slam") == Path("runs/log1/slam")
    assert default_out_dir("/data/aces.log", "smooth") == Path("runs/aces/smooth")


def test_clear_outputs_removes_only_the_commands_files(tmp_path):
    for name in ["slam.gif", "trajectory.tum", "truth.tum", "occupancy.pgm", "notes.txt"]:
        (tmp_path / name).write_text("old\n")
    (tmp_path / "keep").mkdir()
    removed = clear_outputs(tmp_path, SLAM_FILES)
    assert {p.name for p in removed} == {"slam.gif", "trajectory.tum", "truth.tum", "occupancy.pgm"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["keep", "notes.txt"]


def test_slam_writes_under_runs_in_the_current_folder_never_beside_the_log(short_log, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    before = sorted(short_log.parent.iterdir())
    result = invoke("slam", short_log, "--quiet")
    assert result.exit_code == 0, result.output
    out = Path("runs") / "short" / "slam"
    assert (tmp_path / out / "slam.png").is_file()
    assert (tmp_path / out / "map.json").is_file()
    assert result.output.rstrip().splitlines()[-1] == f"results in {out}"
    assert sorted(short_log.parent.iterdir()) == before  # the data folder is untouched


def test_a_rerun_replaces_the_last_runs_files(short_log, tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "slam.gif").write_text("a GIF of an earlier run\n")
    (out / "notes.txt").write_text("the user's own file\n")
    result = invoke("slam", short_log, "--out", out, "--quiet")
    assert result.exit_code == 0, result.output
    assert not (out / "slam.gif").exists()  # not written by this run: the stale one is gone
    assert (out / "notes.txt").read_text() == "the user's own file\n"
    assert (out / "slam.png").is_file()


def test_smooth_refuses_to_write_into_the_run_it_reads(short_log, tmp_path):
    run_dir = tmp_path / "run"
    assert invoke("slam", short_log, "--out", run_dir, "--quiet").exit_code == 0
    result = CliRunner().invoke(
        main, ["smooth", str(short_log), "--association", "from-run", str(run_dir), "--out", str(run_dir)]
    )
    assert result.exit_code != 0
    assert "RUN_DIR" in result.output
    assert (run_dir / "map.json").is_file()
