"""notebooks/exercise4.ipynb runs top to bottom, is committed without outputs, and its links resolve.

The notebook is executed with nbclient in its own folder, as Jupyter runs it: it finds the
repository (``configs/``, ``../shared/data/``) by walking up from there. As papermill does, a cell
after the one tagged ``parameters`` sets smaller sweeps and fewer particles on log1 (``QUICK``) and
an ``OUT_FOLDER`` in a temporary directory, so every cell and figure still runs, in seconds, and
nothing is written into the repository. Its log1 cells (tagged ``log1``) then run again with log1
absent: they say so and skip.
"""

from __future__ import annotations

import copy
import json
import re
from pathlib import Path

import nbformat
import pandas as pd
import pytest
from conftest import PROJECT_ROOT
from nbclient import NotebookClient

REPO = PROJECT_ROOT
NOTEBOOK = REPO / "notebooks" / "exercise4.ipynb"
LOG1 = REPO.parent / "shared" / "data" / "course" / "log1.txt"
#: The sweeps on one seed with 30 s simulated runs, not two seeds driving until each maze is explored;
#: on log1 100 corner FastSLAM particles and 10 grid filter particles, not course.toml's 1000 and 30.
QUICK = "SWEEP_SEEDS = (0,)\nSWEEP_DURATION = 30.0\nLOG1_CORNER_PARTICLES = 100\nLOG1_GRID_PARTICLES = 10"
#: Run after the last cell: how many x tick labels each sweep figure shows, and the pairs that overlap.
TICK_LABEL_CHECK = """
import json

from matplotlib.backends.backend_agg import FigureCanvasAgg


def overlapping_x_tick_labels(figure):
    FigureCanvasAgg(figure).draw()  # shown figures are closed: draw them again, off-screen
    renderer = figure.canvas.get_renderer()
    shown, overlapping = 0, []
    for ax in figure.axes:
        low, high = sorted(ax.get_xlim())
        labels = [
            label
            for label in ax.get_xticklabels() + ax.get_xticklabels(minor=True)
            if label.get_visible() and label.get_text() and low <= label.get_position()[0] <= high
        ]
        boxes = [label.get_window_extent(renderer) for label in labels]
        shown += len(labels)
        overlapping += [
            (labels[i].get_text(), labels[j].get_text())
            for i in range(len(labels))
            for j in range(i + 1, len(labels))
            if boxes[i].overlaps(boxes[j])
        ]
    return shown, overlapping


figures = {"particles": fig_a, "odometry": fig_b, "sensor": fig_c, "scan points": fig_n}
print(json.dumps({name: overlapping_x_tick_labels(figure) for name, figure in figures.items()}))
"""


def with_parameters(notebook, source: str):
    """``notebook`` with a cell of ``source`` after its cell tagged ``parameters`` (papermill's way)."""
    tagged = [i for i, cell in enumerate(notebook.cells) if "parameters" in tags(cell)]
    assert len(tagged) == 1, "the notebook needs exactly one cell tagged 'parameters'"
    injected = nbformat.v4.new_code_cell(source, metadata={"tags": ["injected-parameters"]})
    notebook.cells.insert(tagged[0] + 1, injected)
    return notebook


def tags(cell) -> list[str]:
    return cell.metadata.get("tags", [])


def execute(notebook, folder: Path):
    """``notebook`` run in ``folder`` (its working folder); raises ``CellExecutionError`` on any error."""
    resources = {"metadata": {"path": str(folder)}}
    NotebookClient(notebook, timeout=180, kernel_name="python3", resources=resources).execute()
    return notebook


def text_of(cell) -> str:
    """What a code cell printed (streams and plain-text results)."""
    parts = [output.get("text", "") for output in cell.outputs if output.output_type == "stream"]
    parts += [output.get("data", {}).get("text/plain", "") for output in cell.outputs if "data" in output]
    return "".join(parts)


def test_notebook_is_committed_without_outputs():
    notebook = nbformat.read(NOTEBOOK, as_version=4)
    code = [cell for cell in notebook.cells if cell.cell_type == "code"]
    assert code
    assert all(not cell.outputs and cell.execution_count is None for cell in code)


def test_links_resolve_from_the_notebooks_folder():
    """Jupyter opens a notebook's relative links from the notebook's folder."""
    notebook = nbformat.read(NOTEBOOK, as_version=4)
    markdown = "\n".join(cell.source for cell in notebook.cells if cell.cell_type == "markdown")
    targets = re.findall(r"\]\(([^)#\s]+)\)", markdown)
    assert len(targets) >= 5  # the log1 section's and Where next's
    missing = [target for target in targets if not (NOTEBOOK.parent / target).exists()]
    assert not missing


def images_in(cells) -> int:
    return sum("image/png" in output.get("data", {}) for cell in cells for output in cell.get("outputs", []))


def files_under(folder: Path) -> set[Path]:
    return {path for path in folder.rglob("*") if "__pycache__" not in path.parts}


@pytest.mark.slow
def test_notebook_runs_top_to_bottom(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    """Run as Jupyter runs it, in notebooks/ (no ``MAZESLAM_REPO``: the repository is found by walking
    up), writing only into ``OUT_FOLDER``; then its log1 cells again with log1 absent: they skip."""
    monkeypatch.delenv("MAZESLAM_REPO", raising=False)
    out = tmp_path / "runs" / "notebook"
    notebook = with_parameters(nbformat.read(NOTEBOOK, as_version=4), f"{QUICK}\nOUT_FOLDER = {str(out)!r}")
    log1_cells = [cell for cell in notebook.cells if "log1" in tags(cell)]
    assert len(log1_cells) >= 4
    absent = tmp_path / "absent" / "log1.txt"
    rerun = [nbformat.v4.new_code_cell(f"LOG1 = {str(absent)!r}"), *(copy.deepcopy(cell) for cell in log1_cells)]
    for cell in rerun:
        cell.metadata["tags"] = ["log1-absent"]
    notebook.cells += [nbformat.v4.new_code_cell(TICK_LABEL_CHECK), *rerun]
    before = files_under(NOTEBOOK.parent)
    execute(notebook, NOTEBOOK.parent)
    assert files_under(NOTEBOOK.parent) == before  # nothing written beside the notebook
    code = [cell for cell in notebook.cells if cell.cell_type == "code"]
    assert f"repository: {REPO.resolve()} | outputs: {out}" in text_of(code[2])

    # The maze, the scan, the map, NEES/NIS, the four sweeps, the blind cloud; with log1 its scan and maps.
    assert images_in(notebook.cells) == 9 + (2 if LOG1.exists() else 0)
    for name in ("maze.log", "maze.png", "slam.png"):
        assert (out / name).stat().st_size > 0
    particle_runs = (out / "sweeps" / "particles" / "runs.jsonl").read_text().splitlines()
    assert len(particle_runs) == 3  # three particle counts on the one seed QUICK sets

    # The sweeps' x axes: a label per swept value (two axes each), none overlapping another.
    checks = json.loads(text_of(next(cell for cell in notebook.cells if cell.source == TICK_LABEL_CHECK)))
    assert {name: shown for name, (shown, _) in checks.items()} == dict.fromkeys(checks, 6)
    assert {name: overlapping for name, (_, overlapping) in checks.items()} == dict.fromkeys(checks, [])

    # Without log1 the section says so, draws nothing, and still shows the measured answer.
    skipped = [cell for cell in notebook.cells if "log1-absent" in tags(cell)]
    assert f"SKIPPED: {absent} is not here" in "".join(text_of(cell) for cell in skipped)
    assert images_in(skipped) == 0
    log1_text = "".join(text_of(cell) for cell in notebook.cells if "log1" in tags(cell))
    assert "experiments/course_robot/filters.csv: log1, median over filter seeds" in log1_text
    if not LOG1.exists():
        assert "SKIPPED" in log1_text
        return
    # log1: its beams as detected, both filters, the sharpness as `mazeslam slam` prints it.
    detected = "beam 0 assumed by the exercise at -180 deg; used here: detected from the scans: beam 0 at 0 deg"
    assert detected in log1_text
    assert "Map sharpness (scan returns of 0.05-0.4 m placed along each path" in log1_text
    assert (out / "log1_maps.png").stat().st_size > 0
    table = pd.read_csv(out / "log1_sharpness.csv", index_col="path")
    assert table.loc["dead reckoning", "cells / dead reckoning's"] == 1.0
    grid, corners = table.loc["grid filter, mean path"], table.loc["corner FastSLAM, mean path"]
    assert (grid["particles"], corners["particles"]) == (10, 100)
    # The grid filter's walls are far sharper than corner FastSLAM's, at dead reckoning's extent, in a tight cloud.
    assert grid["cells / dead reckoning's"] < 0.6 < corners["cells / dead reckoning's"]
    assert 0.95 < grid["extent / dead reckoning's"] < 1.05
    assert grid["final cloud spread, 1 std [m]"] < 0.02
    assert corners["final cloud spread, 1 std [m]"] > 0.05
    assert table.loc["corner FastSLAM, best particle", "cells / dead reckoning's"] > 1.0
