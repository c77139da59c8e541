"""notebooks/exercise4.ipynb runs top to bottom and is committed without outputs.

The notebook is executed with nbclient in a temporary working directory, so everything it writes
(``runs/notebook/``) lands there, never in the repository; ``MAZESLAM_REPO`` tells it where the
repository (``configs/``, ``../shared/data/``) is. As papermill does, a cell after the one tagged
``parameters`` sets smaller sweeps (``QUICK``): every cell and figure still runs, in seconds.
"""

from __future__ import annotations

from pathlib import Path

import nbformat
import pytest
from conftest import PROJECT_ROOT
from nbclient import NotebookClient

REPO = PROJECT_ROOT
NOTEBOOK = REPO / "notebooks" / "exercise4.ipynb"
#: The sweeps on one seed with 30 s simulated runs, not two seeds driving until each maze is explored.
QUICK = "SWEEP_SEEDS = (0,)\nSWEEP_DURATION = 30.0"


def with_parameters(notebook, source: str):
    """``notebook`` with a cell of ``source`` after its cell tagged ``parameters`` (papermill's way)."""
    tagged = [i for i, cell in enumerate(notebook.cells) if "parameters" in cell.metadata.get("tags", [])]
    assert len(tagged) == 1, "the notebook needs exactly one cell tagged 'parameters'"
    injected = nbformat.v4.new_code_cell(source, metadata={"tags": ["injected-parameters"]})
    notebook.cells.insert(tagged[0] + 1, injected)
    return notebook


def test_notebook_is_committed_without_outputs():
    notebook = nbformat.read(NOTEBOOK, as_version=4)
    code = [cell for cell in notebook.cells if cell.cell_type == "code"]
    assert code
    assert all(not cell.outputs and cell.execution_count is None for cell in code)


@pytest.mark.slow
def test_notebook_runs_top_to_bottom(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    monkeypatch.setenv("MAZESLAM_REPO", str(REPO))
    notebook = with_parameters(nbformat.read(NOTEBOOK, as_version=4), QUICK)
    client = NotebookClient(
        notebook, timeout=180, kernel_name="python3", resources={"metadata": {"path": str(tmp_path)}}
    )
    client.execute()  # raises CellExecutionError, with the cell and its traceback, on any error
    errors = [o for cell in notebook.cells for o in cell.get("outputs", []) if o.output_type == "error"]
    assert not errors
    images = sum("image/png" in o.get("data", {}) for cell in notebook.cells for o in cell.get("outputs", []))
    assert images >= 9  # the maze, the scan, the map, NEES/NIS, the four sweeps, the blind cloud
    for name in ("maze.log", "maze.png", "slam.png"):
        assert (tmp_path / "runs" / "notebook" / name).stat().st_size > 0
    particle_runs = (tmp_path / "runs" / "notebook" / "sweeps" / "particles" / "runs.jsonl").read_text().splitlines()
    assert len(particle_runs) == 3  # three particle counts on the one seed QUICK sets
