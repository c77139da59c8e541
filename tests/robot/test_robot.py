"""The robot side without hardware: the e-puck driver against an emulated e-puck on a pty, the
camera's image-to-range conversion against rendered images, the recorder end to end, and faults."""

import math

import numpy as np
import pytest
from conftest import PROJECT_ROOT

from mazeslam.core.beams import EXERCISE_CONVENTION
from mazeslam.core.mirror import CameraCalibration
from mazeslam.data import log, sidecars
from mazeslam.robot.emulator import EPuckEmulator, RenderedCamera
from mazeslam.robot.epuck import EPuck
from mazeslam.robot.interface import RobotDisconnected, RobotError
from mazeslam.robot.omnicam import OmniCamera, detect_mirror, image_to_ranges
from mazeslam.robot.recorder import Recorder, ScriptedController
from mazeslam.robot.simulated import SimulatedRobot
from mazeslam.sim.laser import RayCaster
from mazeslam.sim.maze import generate_maze, load_maze, parse_maze

ROOM = parse_maze("cell_size = 0.5\nwall_thickness = 0.01\n+---+\n|   |\n+---+\n")
CALIBRATION = CameraCalibration(160, 160, 40, 150)


@pytest.fixture
def emulated():
    robot = SimulatedRobot(ROOM, seed=0, start_pose=np.array([0.25, 0.25, 0.0]))
    emulator = EPuckEmulator(robot)
    yield robot, emulator
    emulator.close()


def test_driver_odometry_follows_the_emulated_robot(emulated):
    robot, emulator = emulated
    epuck = EPuck(emulator.port)
    epuck.set_wheel_speeds(0.05, 0.05)
    travelled = sum(epuck.read_odometry()[0] for _ in range(50))  # 50 commands x 0.02 s = 1 s
    assert travelled == pytest.approx(0.05, abs=0.002)
    assert robot.pose[0] - 0.25 == pytest.approx(travelled, abs=0.003)  # the truth moved as much
    epuck.set_wheel_speeds(-0.02, 0.02)  # turn on the spot
    turned = sum(epuck.read_odometry()[1] for _ in range(50))
    assert turned == pytest.approx(0.04 * 1.0 / robot.config.robot.wheelbase, rel=0.05)
    epuck.close()
    assert robot.speeds == (0.0, 0.0)  # 'S' stopped it


def test_speed_commands_are_steps_per_second_and_clipped(emulated):
    robot, emulator = emulated
    epuck = EPuck(emulator.port)
    epuck.set_wheel_speeds(10.0, -0.5 * 2 * math.pi * 0.0205)  # far too fast; half a turn a second back
    assert robot.speeds[0] == pytest.approx(1000 * epuck.metres_per_step)
    assert robot.speeds[1] == pytest.approx(-500 * epuck.metres_per_step)


def test_garbled_replies_are_named(emulated):
    _, emulator = emulated
    epuck = EPuck(emulator.port)
    emulator.garble = True
    with pytest.raises(RobotError, match=r"answered '#@!' to 'Q', expected 'q'"):
        epuck.read_odometry()


def test_a_robot_that_goes_away_mid_run(emulated):
    _, emulator = emulated
    epuck = EPuck(emulator.port, timeout=0.2)
    epuck.read_odometry()
    emulator.close()
    with pytest.raises(RobotDisconnected, match="went away|did not answer"):
        epuck.read_odometry()


def test_a_port_that_does_not_exist():
    with pytest.raises(RobotDisconnected, match="cannot open the e-puck's port /dev/no-such-port"):
        EPuck("/dev/no-such-port")


def test_image_to_ranges_against_true_ranges():
    maze = generate_maze(4, 4, 1)
    errors, truths = [], []
    for k in range(12):
        robot = SimulatedRobot(maze, start_pose=np.array([*maze.cell_center(k % 4, k // 4 % 4), 0.5 * k]))
        _, frame = RenderedCamera(robot, CALIBRATION, 320).read()
        ranges = image_to_ranges(frame, CALIBRATION, EXERCISE_CONVENTION, 180)
        true = RayCaster(robot.walls.surfaces, EXERCISE_CONVENTION.bearings(180), 5.0).cast(*robot.pose)
        visible = (true > CALIBRATION.distance(41)) & (true < CALIBRATION.distance(149))
        assert np.all(ranges[true > CALIBRATION.distance(150)] == 0)  # beyond the mirror: no return
        errors.append(ranges[visible] - true[visible])
        truths.append(true[visible])
    errors, truths = np.concatenate(errors), np.concatenate(truths)
    near = truths < 0.2
    assert np.median(np.abs(errors[near])) < 0.002  # ~1 mm up to 20 cm (pixels are ~1 mm there)
    assert np.median(np.abs(errors[~near])) < 0.01  # a pixel spans cm far out


def test_otsu_threshold_and_lookup_table_agree_with_the_fixed_model():
    maze = generate_maze(3, 3, 2)
    robot = SimulatedRobot(maze, start_pose=np.array([*maze.cell_center(1, 1), 0.3]))
    _, frame = RenderedCamera(robot, CALIBRATION, 320).read()
    fixed = image_to_ranges(frame, CALIBRATION, EXERCISE_CONVENTION, 90)
    otsu = image_to_ranges(frame, CameraCalibration(160, 160, 40, 150, threshold="otsu"), EXERCISE_CONVENTION, 90)
    radii = np.linspace(30, 160, 200)
    table = CameraCalibration(
        160, 160, 40, 150, table_radii=tuple(radii), table_distances=tuple(CALIBRATION.distance(radii))
    )
    looked_up = image_to_ranges(frame, table, EXERCISE_CONVENTION, 90)
    seen = fixed > 0
    np.testing.assert_allclose(looked_up[seen], fixed[seen], rtol=0.01)
    assert np.median(np.abs(otsu[seen] - fixed[seen])) < 0.003


def test_mirror_detection_finds_the_ring():
    robot = SimulatedRobot(ROOM, start_pose=np.array([0.25, 0.25, 0.0]))
    _, frame = RenderedCamera(robot, CALIBRATION, 320).read()
    x, y, radius = detect_mirror(frame)
    assert math.hypot(x - 160, y - 160) < 3 and abs(radius - 150) < 5


def test_camera_without_frames():
    class Dead:
        def read(self):
            return False, None

    camera = OmniCamera(Dead(), CALIBRATION, EXERCISE_CONVENTION, 90)
    with pytest.raises(RobotDisconnected, match="returned no frame"):
        camera()
    with pytest.raises(RobotDisconnected, match="cannot open camera"):
        OmniCamera("/no/such/video.avi", CALIBRATION, EXERCISE_CONVENTION, 90)


def recording_setup(tmp_path):
    maze = load_maze(PROJECT_ROOT / "configs" / "mazes" / "paper_sheet.txt")
    robot = SimulatedRobot(maze, seed=3, start_pose=np.array([*maze.cell_center(0, 0), 0.0]))
    emulator = EPuckEmulator(robot, seconds_per_command=0.05)
    camera = OmniCamera(RenderedCamera(robot, CALIBRATION, 320), CALIBRATION, EXERCISE_CONVENTION, 90)
    epuck = EPuck(emulator.port, scanner=camera, timeout=0.2)
    # The emulated robot moves only when spoken to: let the recorder's waits run its clock.
    recorder = Recorder(
        epuck,
        tmp_path / "real.log",
        90,
        EXERCISE_CONVENTION,
        scan_period=0.5,
        odometry_rate=5.0,
        clock=lambda: robot.time,
        wait=lambda seconds: epuck.read_counts() if seconds > 0 else None,
    )
    return robot, emulator, recorder


def test_recorder_on_the_emulated_e_puck_writes_a_valid_log(tmp_path):
    robot, emulator, recorder = recording_setup(tmp_path)
    records = recorder.run(ScriptedController([(2.0, 0.04, 0.0), (1.0, 0.0, 0.6)]))
    emulator.close()
    course_log = log.read(tmp_path / "real.log")
    assert len(course_log) == records and course_log.n_beams == 90
    assert course_log.odometry[:, 0].sum() == pytest.approx(0.08, abs=0.01)
    assert (course_log.scans > 0).mean() > 0.8  # the camera saw walls all round
    geometry = sidecars.beam_geometry(sidecars.read_map(sidecars.map_path(tmp_path / "real.log"))["sensor"])
    assert geometry == EXERCISE_CONVENTION


def test_recorder_keeps_the_log_when_the_robot_goes_away(tmp_path):
    robot, emulator, recorder = recording_setup(tmp_path)
    controller = ScriptedController([(10.0, 0.03, 0.0)])

    def unplug_after_two_seconds(t):
        if t > 2.0:
            emulator.close()
        return controller(t)

    with pytest.raises(RobotDisconnected, match=r"keeps the \d+ records written before it"):
        recorder.run(unplug_after_two_seconds)
    course_log = log.read(tmp_path / "real.log")  # every line complete: it reads without error
    assert len(course_log) == recorder.records > 5
    assert sidecars.map_path(tmp_path / "real.log").exists()


def test_record_command_on_the_simulator(tmp_path):
    from click.testing import CliRunner

    from mazeslam.cli.main import main

    script = tmp_path / "drive.txt"
    script.write_text("2 0.04 0\n1 0 0.8\n")
    result = CliRunner().invoke(
        main,
        [
            "record",
            "--sim",
            "--out",
            str(tmp_path / "sim.log"),
            "--script",
            str(script),
            "--maze",
            str(PROJECT_ROOT / "configs" / "mazes" / "paper_sheet.txt"),
            "--beams",
            "120",
        ],
    )
    assert result.exit_code == 0, result.output
    course_log = log.read(tmp_path / "sim.log")
    assert course_log.n_beams == 120 and course_log.duration == pytest.approx(2.8, abs=0.3)
    assert sidecars.truth_path(tmp_path / "sim.log").exists()
    refused = CliRunner().invoke(main, ["record", "--out", str(tmp_path / "x.log"), "--script", str(script)])
    assert refused.exit_code != 0


def test_the_gymnasium_env_drives_the_emulated_e_puck():
    from mazeslam.envs.hardware_env import HardwareMazeEnv

    maze = load_maze(PROJECT_ROOT / "configs" / "mazes" / "paper_sheet.txt")
    robot = SimulatedRobot(maze, seed=1, start_pose=np.array([*maze.cell_center(0, 0), 0.0]))
    emulator = EPuckEmulator(robot, seconds_per_command=0.1)
    camera = OmniCamera(RenderedCamera(robot, CALIBRATION, 320), CALIBRATION, EXERCISE_CONVENTION, 180)
    env = HardwareMazeEnv(EPuck(emulator.port, scanner=camera), control_period=0.05)
    observation, info = env.reset()
    assert observation["scan"].shape == (180,) and (observation["scan"] > 0).mean() > 0.8
    for _ in range(5):
        observation, reward, terminated, truncated, info = env.step(np.array([0.3, 0.0], dtype=np.float32))
    assert reward == 0.0 and not terminated and set(info) == {"time"}  # no ground truth on a real robot
    assert observation["odometry"][0] > 0  # it drove forward
    assert robot.pose[0] > maze.cell_center(0, 0)[0]
    env.close()
    emulator.close()


def test_keyboard_teleoperation_on_a_terminal(monkeypatch):
    import io
    import os
    import sys

    from mazeslam.robot.recorder import KeyboardController

    master, slave = os.openpty()
    terminal = io.TextIOWrapper(os.fdopen(slave, "rb", buffering=0), encoding="ascii")
    monkeypatch.setattr(sys, "stdin", terminal)
    controller = KeyboardController(max_speed=0.13, max_turn_rate=4.9)
    try:
        os.write(master, b"www")  # three presses arriving together
        assert wait_for(lambda: controller(0.0).speed == pytest.approx(0.03))
        os.write(master, b"a")
        assert wait_for(lambda: controller(0.0).turn_rate == pytest.approx(0.25))
        os.write(master, b" ")
        assert wait_for(lambda: controller(0.0).speed == 0.0 and controller(0.0).turn_rate == 0.0)
        os.write(master, b"q")
        assert wait_for(lambda: controller(0.0).quit)
    finally:
        controller.close()
        os.close(master)


def wait_for(condition, seconds=2.0):
    import time

    deadline = time.time() + seconds
    while time.time() < deadline:
        if condition():
            return True
        time.sleep(0.01)
    return False
