"""Issue 35: importing mazeslam chooses no matplotlib backend. Files are drawn on an Agg canvas of
their own whatever pyplot's backend is; windows (--live, the env's "human" mode, the examples'
--render) get the user's interactive backend. Each check runs in a fresh interpreter, where the
backend has not been chosen yet."""

import subprocess
import sys

import pytest
from conftest import PROJECT_ROOT

from mazeslam.viz.backends import is_interactive

#: Every module that draws, imported together (each forced Agg on import before).
DRAWING_MODULES = (
    "mazeslam.envs.rendering",
    "mazeslam.viz.plots",
    "mazeslam.viz.corner_plots",
    "mazeslam.viz.corner_report",
    "mazeslam.viz.slam_view",
    "mazeslam.viz.slam_figure",
    "mazeslam.viz.grid_animation",
    "mazeslam.viz.live",
    "mazeslam.sweeps.report",
)


def python(code: str, **environment) -> list[str]:
    """The lines ``code`` prints in a fresh interpreter with ``environment`` (and no display)."""
    env = {"PATH": "/usr/bin:/bin", "HOME": str(PROJECT_ROOT), **environment}
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, cwd=PROJECT_ROOT, env=env, timeout=120
    )
    assert done.returncode == 0, done.stderr
    return done.stdout.split()


def test_importing_every_drawing_module_leaves_the_users_backend(tmp_path):
    """With the user's backend set (here the file-only "svg", as an interactive one would be set),
    importing mazeslam's drawing modules and drawing files and env frames keeps it."""
    code = f"""
import importlib, gymnasium, matplotlib, numpy as np, mazeslam
for name in {DRAWING_MODULES!r}:
    importlib.import_module(name)
from mazeslam.viz.plots import plot_run
env = gymnasium.make("mazeslam/Maze-v0", rows=2, cols=2, render_mode="rgb_array")
env.reset(seed=0)
frame = env.render()
plot_run({str(tmp_path / "run.png")!r}, np.zeros((1, 4)), np.zeros((0, 2)), np.zeros((2, 3)), {{}}, "t")
print(matplotlib.get_backend(), frame.shape[2], frame.std() > 0)
"""
    assert python(code, MPLBACKEND="svg") == ["svg", "3", "True"]
    assert (tmp_path / "run.png").read_bytes()[:4] == b"\x89PNG"  # the file is a PNG, whatever pyplot's backend


def test_a_window_gets_the_users_backend_and_none_opens_without_a_display():
    """``window_backend`` takes MPLBACKEND when it names an interactive backend (the env's "human"
    mode then draws with it), and without a display falls back to drawing off-screen (Agg)."""
    code = """
import matplotlib
from mazeslam.viz.backends import window_backend
print(*window_backend())
"""
    assert python(code, MPLBACKEND="TkAgg", DISPLAY="") == ["False", "agg"]  # TkAgg cannot open headless
    assert python(code) == ["False", "agg"]
    code = """
import matplotlib.pyplot as plt
from mazeslam.viz.backends import is_interactive
print(is_interactive("TkAgg"), is_interactive("QtAgg"), is_interactive("agg"), is_interactive("svg"))
"""
    assert python(code) == ["True", "True", "False", "False"]


def test_render_without_a_display_says_so_in_one_line_and_runs_without_a_window():
    """The examples' --render: "human" only where a window opens; else one line, and the video's
    frames still drawn when --video is given."""
    code = """
from mazeslam.viz.backends import render_mode
for render, video in ((True, False), (True, True), (False, True), (False, False)):
    mode, note = render_mode(render, video)
    print(mode, "note" if note and "no display" in note and "\\n" not in note else note)
"""
    assert python(code) == ["None", "note", "rgb_array", "note", "rgb_array", "None", "None", "None"]


@pytest.mark.parametrize(
    "backend, window",
    [
        ("TkAgg", True),
        ("QtAgg", True),
        ("agg", False),
        ("pdf", False),
        ("nbAgg", False),
        ("module://matplotlib_inline.backend_inline", False),
    ],
)
def test_only_backends_with_windows_a_user_closes_count_as_interactive(backend, window):
    """Jupyter's inline figures never close: a live view waiting for that would wait forever."""
    assert is_interactive(backend) is window
