"""Output folders and files: checked before any work, written whole or not at all.

A folder is created and probed for writing before a long run (``prepare_output_folder``), so that
the run does not end in a ``PermissionError``. A file is written under a temporary name beside it
and renamed when complete (``written``, ``write_file``): a full disk or an interrupt leaves the
last complete file, never half of one, and the error names the file (``WriteError``). A run's set
of files is written into a staging folder and replaces the previous run's set only once every file
is written (``staged_outputs``): a failed or interrupted run leaves the folder as it was.
"""

from __future__ import annotations

import contextlib
import json
import os
import secrets
import shutil
import signal
import tempfile
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import TextIO

try:
    import fcntl
except ImportError:  # not POSIX: no locks; runs into one folder at once may then mix their files
    fcntl = None  # type: ignore[assignment]

#: How a staging folder's name begins (``<folder>/.staging-<pid>-<random>``).
STAGING_PREFIX = ".staging-"
#: The signals a commit holds until it has moved every file in: Ctrl-C and the polite kill.
DEFERRED_SIGNALS = (signal.SIGINT, signal.SIGTERM)


class OutputError(ValueError):
    """An output folder that cannot be created or written; the message names it."""


class WriteError(OutputError):
    """A file that could not be written (a full disk, a file too large, a folder gone): names it."""

    def __init__(self, path: str | Path, reason: str):
        super().__init__(path, reason)  # both in args: it pickles (a side process raises it here)
        self.path, self.reason = Path(path), reason

    def __str__(self) -> str:
        return f"{self.path}: cannot write: {self.reason}"


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


#: The exception a stop of the command raises (``stop_outputs``), or nothing: while it is set no
#: output replaces a file, the stop is raised at the commit instead (a stop can be swallowed on its
#: way up by library code that catches everything; the run must not then report results).
_STOPPED: list[BaseException] = []


def stop_outputs(reason: BaseException | None) -> None:
    """From now on (``reason``: the exception to raise) or no longer (None), no output this module
    writes replaces a file: ``reason`` is raised where it would (``written``, ``staged_outputs``)."""
    _STOPPED[:] = [] if reason is None else [reason]


def _refuse_if_stopped() -> None:
    """Raise the stop ``stop_outputs`` set, if any."""
    if _STOPPED:
        raise _STOPPED[0]


@contextlib.contextmanager
def written(path: str | Path) -> Iterator[Path]:
    """Write ``path`` whole or not at all: the block writes the temporary path it is given (beside
    ``path``, with its suffix, so that writers choosing a format by suffix still do), which replaces
    ``path`` when the block ends. An error or interrupt removes it and leaves ``path`` as it was; an
    ``OSError`` comes out as a ``WriteError`` naming ``path``."""
    path = Path(path)
    temporary = path.with_name(f".{path.stem}-{os.getpid()}-{secrets.token_hex(4)}.tmp{path.suffix}")
    try:
        yield temporary
        _refuse_if_stopped()
        os.replace(temporary, path)
    except OSError as error:
        raise WriteError(path, error.strerror or str(error)) from error
    finally:
        with contextlib.suppress(OSError):
            temporary.unlink()  # gone already when it was renamed


def write_line(handle: TextIO, path: str | Path, line: str) -> None:
    """Append ``line`` and a newline to ``handle``, the open file ``path``, and flush it (a recording
    keeps every line written); an ``OSError`` (a full disk) comes out as a ``WriteError`` naming ``path``."""
    try:
        handle.write(line + "\n")
        handle.flush()
    except OSError as error:
        raise WriteError(path, error.strerror or str(error)) from error


def close_written(handle: TextIO, path: str | Path) -> None:
    """Close ``handle``, the open file ``path`` (``write_line``'s); a failed last flush is a
    ``WriteError`` naming ``path``."""
    try:
        handle.close()
    except OSError as error:
        raise WriteError(path, error.strerror or str(error)) from error


@contextlib.contextmanager
def staged_file(path: str | Path) -> Iterator[Path]:
    """``path`` and the files written beside it (a log's sidecars) whole or not at all: the block
    writes the path it is given (``path``'s name in a staging folder beside it, ``staged_outputs``)
    and its sidecars beside that; they replace ``path`` and its sidecars once the block ends
    without error. An error or interrupt leaves the folder as it was; a ``WriteError`` names the
    file it was to replace."""
    path = Path(path)
    with staged_outputs(path.parent if str(path.parent) else Path("."), ()) as staging:
        yield staging / path.name


def write_file(path: str | Path, content: str | bytes) -> Path:
    """Write ``content`` (text as UTF-8, or bytes) to ``path`` whole or not at all (``written``); returns ``path``."""
    with written(path) as temporary:
        if isinstance(content, str):
            temporary.write_text(content, encoding="utf-8")
        else:
            temporary.write_bytes(content)
    return Path(path)


def write_json(path: str | Path, document: dict) -> Path:
    """Write ``document`` to ``path`` as strict JSON (``jsonable``: numpy values as plain ones; NaN
    and infinities refused), one space of indent, whole or not at all (``write_file``)."""
    from mazeslam.core.config import jsonable

    return write_file(path, json.dumps(jsonable(document), indent=1, allow_nan=False) + "\n")


def clear_outputs(folder: str | Path, patterns: tuple[str, ...], keep: frozenset[str] = frozenset()) -> list[Path]:
    """Remove the files of ``folder`` matching ``patterns`` (glob patterns), except those named in
    ``keep``, hidden ones (temporary files) and folders; returns those removed."""
    removed = []
    for pattern in patterns:
        for path in sorted(Path(folder).glob(pattern)):
            if path.name in keep or path.name.startswith(".") or not (path.is_file() or path.is_symlink()):
                continue
            path.unlink()
            removed.append(path)
    return removed


@contextlib.contextmanager
def staged_outputs(folder: str | Path, patterns: tuple[str, ...]) -> Iterator[Path]:
    """A run's files, replacing the previous run's only once all are written.

    The block writes its files into the staging folder it is given (inside ``folder``, so on the
    same file system). When it ends without error, the new files are moved into ``folder``
    (``os.replace``) and the files matching ``patterns`` that the run did not write are removed,
    under a lock on ``folder``: two runs into one folder each replace the whole set, and the last
    to finish wins. An error or interrupt in the block leaves ``folder`` as it was. The staging
    folder is removed in every case; one left by a killed run is removed by the next run into
    ``folder``. A ``WriteError`` naming a file of the staging folder comes out naming the file it
    was to replace."""
    folder = Path(folder)
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with _locked(folder):  # no other run takes this staging folder for abandoned before it is locked
            _remove_abandoned_staging(folder)
            staging = Path(tempfile.mkdtemp(prefix=f"{STAGING_PREFIX}{os.getpid()}-", dir=folder))
            in_use = _lock(staging)
    except OSError as error:
        raise OutputError(f"{folder}: cannot write in the output folder: {error.strerror or error}") from error
    try:
        try:
            yield staging
        except WriteError as error:
            if not error.path.is_relative_to(staging):
                raise
            raise WriteError(folder / error.path.relative_to(staging), error.reason) from error
        _refuse_if_stopped()
        with _locked(folder), _signals_deferred():
            new = [path for path in staging.iterdir() if path.is_file()]
            for path in new:
                os.replace(path, folder / path.name)
            clear_outputs(folder, patterns, keep=frozenset(path.name for path in new))
    finally:
        shutil.rmtree(staging, ignore_errors=True)
        if in_use is not None:
            os.close(in_use)


def _remove_abandoned_staging(folder: Path) -> None:
    """Remove the staging folders of runs that were killed: those no process holds locked."""
    if fcntl is None:  # no telling a killed run's folder from a running one's
        return
    for staging in folder.glob(f"{STAGING_PREFIX}*"):
        try:
            handle = _lock(staging, wait=False)
        except OSError:  # gone meanwhile, or not a folder
            continue
        if handle is not None:
            shutil.rmtree(staging, ignore_errors=True)
            os.close(handle)


def _lock(path: Path, wait: bool = True) -> int | None:
    """An open handle on the folder ``path`` holding an exclusive ``flock`` on it (released when it is
    closed or the process ends, however it ends). None when another process holds it (without
    ``wait``) or where there are no such locks (no ``fcntl``; a file system without them)."""
    if fcntl is None:
        return None
    handle = os.open(path, os.O_RDONLY)
    try:
        fcntl.flock(handle, fcntl.LOCK_EX | (0 if wait else fcntl.LOCK_NB))
    except OSError:  # held by another (BlockingIOError), or no locks here
        os.close(handle)
        return None
    except BaseException:
        os.close(handle)
        raise
    return handle


@contextlib.contextmanager
def _locked(folder: Path) -> Iterator[None]:
    """The block run holding the lock on ``folder`` (``_lock``: waits for another run's to end)."""
    handle = _lock(folder)
    try:
        yield
    finally:
        if handle is not None:
            os.close(handle)


@contextlib.contextmanager
def _signals_deferred() -> Iterator[None]:
    """Hold Ctrl-C and SIGTERM (``DEFERRED_SIGNALS``) until the block ends (a few renames), then
    act on them as their handlers would have: a folder is never left with half of one run's files
    and half of another's. Only the main thread can set handlers; elsewhere nothing changes."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught: list[int] = []
    previous = {
        signum: signal.signal(signum, lambda received, frame: caught.append(received))
        for signum in DEFERRED_SIGNALS
        if signal.getsignal(signum) is not None  # None: a handler set outside Python, which cannot be put back
    }
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
    for received in dict.fromkeys(caught):
        handler = previous[signal.Signals(received)]
        if callable(handler):
            handler(received, None)
        elif handler == signal.SIG_DFL:
            signal.raise_signal(received)
