"""notebooks/exercise4.ipynb runs top to bottom (about a minute) and is committed without outputs.

The notebook is executed with nbclient in a temporary working directory, so everything it writes
(``runs/notebook/``) lands there, never in the repository; ``MAZESLAM_REPO`` tells it where the
repository (``configs/``, ``../shared/data/``) is.
"""

from __future__ import annotations

from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient

REPO = Path(__file__).resolve().parents[1]
NOTEBOOK = REPO / "notebooks" / "exercise4.ipynb"


def test_notebook_is_committed_without_outputs():
    notebook = nbformat.read(NOTEBOOK, as_version=4)
    code = [cell for cell in notebook.cells if cell.cell_type == "code"]
    assert code
    assert all(not cell.outputs and cell.execution_count is None for cell in code)


def test_notebook_runs_top_to_bottom(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    monkeypatch.setenv("MAZESLAM_REPO", str(REPO))
    notebook = nbformat.read(NOTEBOOK, as_version=4)
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
