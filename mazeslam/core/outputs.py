"""Output folders checked before any work: created and probed for writing, so that a long run does
not end in a ``PermissionError`` when it writes its results."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path


class OutputError(ValueError):
    """An output folder that cannot be created or written; the message names it."""


def prepare_output_folder(path: str | Path) -> Path:
    """Create the folder ``path`` (and its parents) and check that a file can be written in it;
    returns it. ``OutputError`` naming the folder and the reason otherwise."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise OutputError(f"{path}: cannot write outputs there: it is a file, not a folder")
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise OutputError(f"{path}: cannot create the output folder: {error.strerror or error}") from error
    try:
        handle, probe = tempfile.mkstemp(prefix=".mazeslam-probe-", dir=path)
        os.close(handle)
        os.unlink(probe)
    except OSError as error:
        raise OutputError(f"{path}: cannot write in the output folder: {error.strerror or error}") from error
    return path


def prepare_output_file(path: str | Path) -> Path:
    """``prepare_output_folder`` for the folder of the file ``path``, and ``path`` must not be a folder."""
    path = Path(path)
    if path.is_dir():
        raise OutputError(f"{path}: is a folder; give a file name to write")
    prepare_output_folder(path.parent if str(path.parent) else Path("."))
    return path
