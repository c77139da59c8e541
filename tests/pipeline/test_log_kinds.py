"""Issue 35: without --config, ``mazeslam slam`` and ``slam_on_file`` run the settings under configs/
that fit the log's kind (told by the sidecar the simulator or an import wrote, or by the exercise
robot's scans) and say so in one line; no numpy warning reaches the user, and a numerical failure
says what it means. Each log below is made by the tool the kind names: the truth of its kind."""

import gzip
import math

import numpy as np
import pytest
from cli_runs import cli
from conftest import PROJECT_ROOT

from mazeslam.core.config import InputError, with_settings
from mazeslam.data import log, sidecars
from mazeslam.data.carmen import import_carmen
from mazeslam.data.loaded_run import load_run
from mazeslam.data.mrclam import import_mrclam
from mazeslam.pipeline import MapKind, SlamConfig, load_slam_config, slam_on_file
from mazeslam.pipeline.log_kinds import CONFIGS_FOLDER, LogKind, chosen_config, log_kind
from mazeslam.pipeline.run import NumericalFailure, numbers_checked
from mazeslam.sim.building import simulate_building_log
from mazeslam.sim.laser import cast_rays
from mazeslam.sim.simulator import SimulationConfig

CONFIGS = PROJECT_ROOT / "configs"
#: A 6 x 4 m room, its walls as segments x1, y1, x2, y2 (m).
ROOM = np.array([[-3, -2, 3, -2], [3, -2, 3, 2], [3, 2, -3, 2], [-3, 2, -3, -2]], dtype=float)


def carmen_text(scans: int, odometry: bool = True) -> str:
    """A CARMEN log of a robot driving 0.1 m a scan along x in ``ROOM``: FLASER lines with 181
    beams over the front 180 degrees, ODOM lines between them unless not ``odometry``."""
    lines = ["PARAM robot_front_laser_max 50 h 0"]
    bearings = np.radians(np.arange(-90, 91))
    for k in range(scans):
        x, t = -1.0 + 0.1 * k, 1.0 + k
        ranges = cast_rays((x, 0.0), bearings, ROOM, 50.0)
        if odometry and k:
            lines.append(f"ODOM {x - 0.05:.3f} 0 0 0.1 0 0 {t - 0.5:.3f} h {t - 0.5:.3f}")
        pose = f"{x:.3f} 0 0"
        lines.append(f"FLASER 181 {' '.join(f'{r:.3f}' for r in ranges)} {pose} {pose} {t:.3f} h {t:.3f}")
    return "\n".join(lines) + "\n"


@pytest.fixture
def carmen_log(tmp_path):
    source = tmp_path / "room.clf"
    source.write_text(carmen_text(8))
    import_carmen(source, tmp_path / "room.log")
    return tmp_path / "room.log"


def write_table(folder, name, rows):
    with gzip.open(folder / f"{name}.gz", "wt") as handle:
        handle.write("# header\n" + "\n".join(" ".join(str(v) for v in row) for row in rows) + "\n")


@pytest.fixture
def mrclam_log(tmp_path):
    """Robot 1 of a hand-made MRCLAM dataset: driving 0.1 m/s round a circle for 20 s, seeing landmark 6
    (barcode 30, at (1, 2)) every second, with motion-capture truth."""
    times = np.arange(0, 20.01, 0.1)
    poses = np.column_stack([np.sin(0.1 * times), 1 - np.cos(0.1 * times), 0.1 * times])
    seen = []
    for t in np.arange(0.5, 20, 1.0):
        x, y, theta = np.sin(0.1 * t), 1 - np.cos(0.1 * t), 0.1 * t
        seen.append((t, 30, math.hypot(1 - x, 2 - y), math.atan2(2 - y, 1 - x) - theta))
    write_table(tmp_path, "Robot1_Odometry.dat", [(t, 0.1, 0.1) for t in times])
    write_table(tmp_path, "Robot1_Measurement.dat", seen)
    write_table(tmp_path, "Robot1_Groundtruth.dat", [(t, *pose) for t, pose in zip(times, poses)])
    write_table(tmp_path, "Landmark_Groundtruth.dat", [(6, 1.0, 2.0, 0.001, 0.001)])
    write_table(tmp_path, "Barcodes.dat", [(1, 5), (6, 30)])
    import_mrclam(tmp_path, 1, tmp_path / "robot1.log")
    return tmp_path / "robot1.log"


@pytest.fixture(scope="module")
def course_simulation(tmp_path_factory):
    """30 s of the course robot simulated (configs/simulation_course_robot.toml: its camera)."""
    from mazeslam import simulate
    from mazeslam.core.config import load_toml

    config = load_toml(SimulationConfig, CONFIGS / "simulation_course_robot.toml")
    out = tmp_path_factory.mktemp("course_sim") / "course.log"
    simulate(out, config, seed=1, duration=30.0, progress=False)
    return out


def test_each_kind_of_log_gets_the_config_that_fits_it(
    default_run, course_simulation, course_log_path, carmen_log, mrclam_log, tmp_path
):
    without_odometry = tmp_path / "blind.clf"
    without_odometry.write_text(carmen_text(4, odometry=False))
    import_carmen(without_odometry, tmp_path / "blind.log")
    expected = {
        default_run.log_path: (LogKind.MAZE_SIMULATION, None),
        course_simulation: (LogKind.COURSE_SIMULATION, "course.toml"),
        course_log_path: (LogKind.COURSE_ROBOT, "course.toml"),
        carmen_log: (LogKind.CARMEN, "carmen.toml"),
        tmp_path / "blind.log": (LogKind.CARMEN_WITHOUT_ODOMETRY, "carmen_without_odometry.toml"),
        mrclam_log: (LogKind.MRCLAM, "mrclam.toml"),
    }
    for path, (kind, file) in expected.items():
        choice = chosen_config(path)
        assert (choice.kind, choice.file) == (kind, file), path
        assert choice.config == (load_slam_config(CONFIGS / file) if file else SlamConfig())
        assert "\n" not in choice.line and f"as {path.name} is {kind.value}" in choice.line
        assert choice.line.startswith(f"settings: configs/{file}," if file else "settings: the defaults")


def test_a_real_robot_recording_takes_the_course_robot_settings(tmp_path):
    path = tmp_path / "real.log"
    with log.LogWriter(path, 180) as writer:
        writer.write_scan(0.0, np.full(180, 0.2))
    sidecars.write_map(sidecars.map_path(path), [], [], {"beams": 180}, source="mazeslam record (real robot: no truth)")
    assert log_kind(load_run(path)) is LogKind.REAL_ROBOT and chosen_config(path).file == "course.toml"


def test_a_simulated_building_takes_the_laser_settings(tmp_path):
    simulated = simulate_building_log(tmp_path / "building.log", laps=0.2)
    choice = chosen_config(simulated.path)
    assert choice.kind is LogKind.BUILDING_SIMULATION and choice.file == "carmen.toml"


def test_a_log_of_no_known_kind_runs_the_defaults_and_names_the_other_configs(default_run, tmp_path):
    """Without its sidecars a simulated maze's log is of no kind the scans tell (180 beams): the
    defaults, which are measured on such mazes, and the line names the configs of the other kinds."""
    bare = tmp_path / "bare.log"
    bare.write_bytes(default_run.log_path.read_bytes())
    choice = chosen_config(bare)
    assert choice.kind is LogKind.UNKNOWN and choice.config == SlamConfig()
    assert "configs/course.toml" in choice.line and "configs/mrclam.toml" in choice.line


def test_without_the_configs_folder_the_config_to_give_is_named(course_log_path, tmp_path):
    with pytest.raises(InputError) as error:
        chosen_config(course_log_path, folder=tmp_path)
    assert "wants --config configs/course.toml" in str(error.value) and "\n" not in str(error.value)


def test_slam_on_file_without_a_config_runs_the_chosen_filter_and_says_so(mrclam_log, capsys):
    result = slam_on_file(mrclam_log)
    assert "settings: configs/mrclam.toml" in capsys.readouterr().err
    mrclam = load_slam_config(CONFIGS / "mrclam.toml")
    assert result.kind == MapKind.LANDMARKS
    # mrclam.toml's own settings ran (the defaults refuse a landmark log: sigmaR = 0): the landmark
    # is mapped within a few of its range noise of where it stands.
    assert np.min(np.hypot(*(result.landmarks - [1.0, 2.0]).T)) < 3 * mrclam.fastslam.sigmaR


@pytest.mark.parametrize("kind", ["maze", "course simulation", "course robot", "carmen", "mrclam"])
def test_slam_without_a_config_on_every_kind_of_log_runs_without_a_warning(
    kind, default_run, course_simulation, course_log_path, carmen_log, mrclam_log, tmp_path
):
    path = {
        "maze": default_run.log_path,
        "course simulation": course_simulation,
        "course robot": course_log_path,
        "carmen": carmen_log,
        "mrclam": mrclam_log,
    }[kind]
    config = chosen_config(path)
    status, output = cli("slam", path, "--quiet", "--particles", 5, "--out", tmp_path / "out")
    assert status == 0, output
    assert output.startswith(config.line + "\n")
    assert "Warning" not in output and "warning" not in output
    filter_name = "grid filter" if config.config.map.kind == MapKind.GRID else "FastSLAM"
    assert f"\n{filter_name}: 5 particles" in output


def test_a_numerical_failure_says_what_it_means_and_which_config_fits(mrclam_log):
    """numpy's errors inside a run (a singular matrix; a division by zero, a warning otherwise)
    leave as one line that names the log, the filter, numpy's words and the config that fits."""
    run, config = load_run(mrclam_log), SlamConfig()
    cases = (
        (lambda: np.linalg.inv(np.zeros((2, 2))), "Singular matrix"),
        (lambda: np.log(np.zeros(1)), "divide by zero"),
    )
    for failing, numpys_words in cases:
        with pytest.raises(NumericalFailure) as error, numbers_checked(run, config):
            failing()
        message = str(error.value)
        assert message.startswith(f"{mrclam_log}: the FastSLAM diverged (numpy: ")
        assert numpys_words in message
        assert message.count("--config configs/mrclam.toml") == 1 and "\n" not in message  # said once


def test_a_numerical_failure_does_not_send_the_user_back_to_the_config_that_failed(mrclam_log):
    run = load_run(mrclam_log)
    grid = with_settings(SlamConfig(), {"map.kind": "grid"})
    for config, fits_it in ((grid, True), (load_slam_config(CONFIGS_FOLDER / "mrclam.toml"), False)):
        with pytest.raises(NumericalFailure) as error, numbers_checked(run, config):
            np.linalg.inv(np.zeros((2, 2)))
        assert ("configs/mrclam.toml fits it" in str(error.value)) == fits_it
