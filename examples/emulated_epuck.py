"""Record a course log from an emulated e-puck, without hardware: the real robot's serial protocol on
a pseudo-terminal (``mazeslam.robot.emulator.EPuckEmulator``) with the simulator's world behind it,
and omnidirectional camera images rendered from that world (``RenderedCamera``), read through the
same driver (``EPuck``), camera model (``OmniCamera``) and recorder as the real robot
(docs/robot.md). Linux and macOS (it needs a pseudo-terminal).

    python examples/emulated_epuck.py --out runs/emulated.log
    mazeslam slam runs/emulated.log

The robot drives a script of ``(seconds, speed m/s, turn rate rad/s)`` commands in
configs/mazes/paper_sheet.txt; the log gets a map sidecar with the beam geometry (no truth: a real
robot has none).
"""

import argparse
from pathlib import Path

import numpy as np

from mazeslam.core.beams import EXERCISE_CONVENTION
from mazeslam.core.mirror import CameraCalibration
from mazeslam.robot.emulator import EPuckEmulator, RenderedCamera
from mazeslam.robot.epuck import EPuck
from mazeslam.robot.omnicam import OmniCamera
from mazeslam.robot.recorder import Recorder, ScriptedController
from mazeslam.robot.simulated import SimulatedRobot
from mazeslam.sim.maze import load_maze

MAZE = Path(__file__).resolve().parents[1] / "configs" / "mazes" / "paper_sheet.txt"
#: The rendered camera: a 320 x 320 image, the mirror's centre at (160, 160) px, its ring 40-150 px.
CALIBRATION = CameraCalibration(160, 160, 40, 150)
#: Drive ahead 3 s at 4 cm/s, turn 1.5 s at 1 rad/s, drive ahead 2 s.
SCRIPT = [(3.0, 0.04, 0.0), (1.5, 0.0, 1.0), (2.0, 0.04, 0.0)]


def record(out: Path, beams: int = 90, seed: int = 0) -> int:
    """Record ``SCRIPT`` from the emulated e-puck into ``out``; returns the records written."""
    maze = load_maze(MAZE)
    robot = SimulatedRobot(maze, seed=seed, start_pose=np.array([*maze.cell_center(0, 0), 0.0]))
    emulator = EPuckEmulator(robot, seconds_per_command=0.05)
    camera = OmniCamera(RenderedCamera(robot, CALIBRATION, 320), CALIBRATION, EXERCISE_CONVENTION, beams)
    epuck = EPuck(emulator.port, scanner=camera, timeout=0.2)
    # The emulated robot moves only when spoken to: the recorder's clock is its simulated time.
    recorder = Recorder(
        epuck,
        out,
        beams,
        EXERCISE_CONVENTION,
        scan_period=0.5,
        odometry_rate=5.0,
        clock=lambda: robot.time,
        wait=lambda seconds: epuck.read_counts() if seconds > 0 else None,
    )
    try:
        return recorder.run(ScriptedController(SCRIPT))
    finally:
        emulator.close()


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", type=Path, default=Path("runs/emulated.log"), help="the course log to write")
    parser.add_argument("--beams", type=int, default=90, help="ranges per scan")
    args = parser.parse_args()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    records = record(args.out, args.beams)
    print(f"wrote {args.out}: {records} records from the emulated e-puck; next: mazeslam slam {args.out}")


if __name__ == "__main__":
    main()
