"""Importing mazeslam stays light: the heavy dependencies load only where they are used."""

import subprocess
import sys

from conftest import PROJECT_ROOT

#: Modules that ``import mazeslam, mazeslam.data.log`` must not load.
HEAVY = ("pymunk", "gymnasium", "matplotlib", "pandas", "cv2", "scipy", "tqdm")


def run_python(code: str) -> str:
    """Run ``code`` in a fresh interpreter (nothing imported yet) and return what it printed."""
    return subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=PROJECT_ROOT
    ).stdout


def test_importing_mazeslam_and_its_log_reader_loads_nothing_heavy():
    printed = run_python(f"import sys, mazeslam, mazeslam.data.log; print(*[m for m in {HEAVY!r} if m in sys.modules])")
    assert printed.split() == []


def test_the_simulator_and_the_environment_are_there_on_first_use():
    printed = run_python(
        "import gymnasium, mazeslam\n"
        "env = gymnasium.make('mazeslam/Maze-v0')\n"
        "observation, info = env.reset(seed=0)\n"
        "print(observation['scan'].shape, mazeslam.simulate.__module__, mazeslam.SimulationConfig().laser.beams)\n"
    )
    assert printed.split() == ["(180,)", "mazeslam.sim.simulator", "180"]


def test_the_environment_is_registered_whichever_is_imported_first():
    for first, second in (("mazeslam", "gymnasium"), ("gymnasium", "mazeslam")):
        printed = run_python(f"import {first}, {second}\nprint(gymnasium.spec('mazeslam/Maze-v0').max_episode_steps)")
        assert printed.split() == ["3000"]


def test_an_unknown_attribute_is_an_attribute_error():
    import mazeslam

    assert not hasattr(mazeslam, "simulator_that_does_not_exist")
    assert {"simulate", "SimulationConfig"} <= set(dir(mazeslam))


def test_the_chi_square_bounds_written_out_are_scipys():
    from scipy.stats import chi2

    from mazeslam.evaluation.consistency import OBSERVATION_BOUND_95, POSE_BOUND_95

    assert (POSE_BOUND_95, OBSERVATION_BOUND_95) == (chi2.ppf(0.95, 3), chi2.ppf(0.95, 2))


def test_loading_a_grid_config_and_the_filter_module_does_not_load_numba():
    printed = run_python(
        "import sys\n"
        "from mazeslam.pipeline import load_slam_config\n"
        "import mazeslam.gridslam.filter\n"
        "config = load_slam_config('configs/carmen.toml')\n"
        "print(config.grid.particles, 'numba' in sys.modules)\n"
    )
    assert printed.split() == ["30", "False"]
