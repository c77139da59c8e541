"""Importing mazeslam stays light: the heavy dependencies load only where they are used."""

import subprocess
import sys

from conftest import PROJECT_ROOT

#: Modules that ``import mazeslam, mazeslam.log`` must not load. (Gymnasium is loaded: the package
#: registers ``mazeslam/Maze-v0`` on import, and Gymnasium >= 1.0 has no lazy plugin registration.)
HEAVY = ("pymunk", "matplotlib", "pandas", "cv2", "scipy.spatial")


def run_python(code: str) -> str:
    """Run ``code`` in a fresh interpreter (nothing imported yet) and return what it printed."""
    return subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=PROJECT_ROOT
    ).stdout


def test_importing_mazeslam_and_its_log_reader_loads_nothing_heavy():
    printed = run_python(f"import sys, mazeslam, mazeslam.log; print(*[m for m in {HEAVY!r} if m in sys.modules])")
    assert printed.split() == []


def test_the_simulator_and_the_environment_are_there_on_first_use():
    printed = run_python(
        "import gymnasium, mazeslam\n"
        "env = gymnasium.make('mazeslam/Maze-v0')\n"
        "observation, info = env.reset(seed=0)\n"
        "print(observation['scan'].shape, mazeslam.simulate.__module__, mazeslam.SimulationConfig().laser.beams)\n"
    )
    assert printed.split() == ["(180,)", "mazeslam.envs.simulator", "180"]


def test_an_unknown_attribute_is_an_attribute_error():
    import mazeslam

    assert not hasattr(mazeslam, "simulator_that_does_not_exist")
    assert {"simulate", "SimulationConfig"} <= set(dir(mazeslam))
