"""Which matplotlib backend draws what, chosen per use; importing mazeslam chooses none.

Figures written to files (``slam.png``, animations, the Gymnasium env's ``rgb_array`` frames, the
report's plots) are drawn on a figure with an off-screen Agg canvas of its own (``file_figure``),
whatever pyplot's backend is: no window opens, and a notebook's or a script's backend is left as
it was. A window (``mazeslam slam --live``, ``corners --live``, the env's ``human`` render mode,
the examples' ``--render``) uses pyplot with the user's interactive backend (``window_backend``):
``MPLBACKEND`` when set, else the first of ``WINDOW_BACKENDS`` that opens on the display.
"""

from __future__ import annotations

import os
import sys
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from matplotlib.figure import Figure

#: Backends tried for a window, in order, when ``MPLBACKEND`` does not name one.
WINDOW_BACKENDS = ("QtAgg", "TkAgg", "GTK4Agg", "GTK3Agg", "macosx")
#: Backends (lower case) that draw only to files or memory.
NON_INTERACTIVE = {"agg", "pdf", "ps", "svg", "pgf", "cairo", "template"}


def file_figure(**kwargs) -> Figure:
    """A ``matplotlib.figure.Figure`` (``kwargs``: figsize, layout, ...) on an Agg canvas of its own,
    for a file or an image array: not pyplot's, so no window, and pyplot's backend untouched."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    figure = Figure(**kwargs)
    FigureCanvasAgg(figure)
    return figure


def close_figure(figure) -> None:
    """Close ``figure`` if it is pyplot's (a window's); a ``file_figure`` is freed with its last reference."""
    pyplot = sys.modules.get("matplotlib.pyplot")
    if pyplot is not None:
        pyplot.close(figure)


def has_display() -> bool:
    """A display a window could open on: always on macOS and Windows, else ``DISPLAY`` or ``WAYLAND_DISPLAY``."""
    return sys.platform in ("darwin", "win32") or bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def window_backend() -> tuple[bool, str]:
    """Switch pyplot to a window backend if there is a display; returns (whether a window can
    open, the backend in use). ``MPLBACKEND`` is obeyed when set; without a window pyplot draws
    off-screen (Agg)."""
    import matplotlib
    import matplotlib.pyplot as plt

    wanted = os.environ.get("MPLBACKEND")
    candidates = [wanted] if wanted else (WINDOW_BACKENDS if has_display() else ())
    for backend in candidates:
        try:
            plt.switch_backend(backend)
        except (ImportError, RuntimeError, ValueError):
            continue
        return is_interactive(matplotlib.get_backend()), matplotlib.get_backend()
    plt.switch_backend("Agg")
    return False, "agg"


def is_interactive(backend: str) -> bool:
    """``backend`` (a matplotlib backend's name) draws into windows a user closes: not a file
    backend, nor Jupyter's inline ones (their figures never close, so a view waiting for that would
    wait forever)."""
    name = backend.lower()
    return name not in NON_INTERACTIVE and "inline" not in name and name != "nbagg"


def render_mode(render: bool, video: bool) -> tuple[str | None, str | None]:
    """The Gymnasium env's ``render_mode`` for a script's ``--render`` (a window) and ``--video`` (frames
    for a file), and a line to print when ``--render`` cannot open a window (None when it can):
    "human" with the user's window backend (``window_backend``), else "rgb_array" for a video or None."""
    if render:
        window, backend = window_backend()
        if window:
            return "human", None
        note = f"--render: no display for a window (matplotlib backend {backend}); running without one"
        return ("rgb_array" if video else None), note + ("" if video else " (--video FOLDER writes an MP4)")
    return ("rgb_array" if video else None), None
