"""The ``mazeslam`` group's way of holding its commands: each is imported only when it runs.

A command lives in its own module (``mazeslam.cli.slam`` holds ``mazeslam slam``), and some of those
modules load the filters, the simulator or matplotlib as they are imported (about 0.3 s). The group
holds a ``LazyCommand`` for each instead: ``mazeslam --help`` lists the commands from their
docstrings, read from the modules' source without running it, and ``mazeslam <command>`` imports
that command's module alone.
"""

from __future__ import annotations

import importlib
import importlib.util
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import click


class LazyCommand(click.Command):
    """Stands in for the click command ``attribute`` of ``module`` (named ``name``) in a ``LazyGroup``.

    Its help, for the group's list of commands, is the docstring of the function ``attribute`` in
    the module's source, as click takes it; without one there (no source, a help given another way)
    the module is imported to ask the command itself."""

    def __init__(self, name: str, module: str, attribute: str):
        super().__init__(name)
        self.module, self.attribute = module, attribute
        self._help_read = False

    def load(self) -> click.Command:
        """The command itself (its module imported)."""
        command = getattr(importlib.import_module(self.module), self.attribute)
        if not isinstance(command, click.Command):
            raise TypeError(f"{self.module}.{self.attribute} is not a click command")
        return command

    def get_short_help_str(self, limit: int = 45) -> str:
        if not self._help_read:
            self.help, self._help_read = _function_docstring(self.module, self.attribute), True
        if self.help is None:
            return self.load().get_short_help_str(limit)
        return super().get_short_help_str(limit)


class LazyGroup(click.Group):
    """A click group of ``LazyCommand`` (and ordinary commands): a command is imported when the
    group looks it up to run it or show its help, and replaces its stand-in; the group's own list
    of commands (``--help``, shell completion) is made from the stand-ins."""

    _listing = False

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        command = super().get_command(ctx, cmd_name)
        if isinstance(command, LazyCommand) and not self._listing:
            command = self.commands[cmd_name] = command.load()
        return command

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        with self._stand_ins():
            super().format_commands(ctx, formatter)

    def shell_complete(self, ctx: click.Context, incomplete: str) -> list:
        with self._stand_ins():
            return super().shell_complete(ctx, incomplete)

    @contextmanager
    def _stand_ins(self) -> Iterator[None]:
        """Meanwhile, ``get_command`` returns the stand-ins without importing their commands."""
        self._listing = True
        try:
            yield
        finally:
            self._listing = False


def _function_docstring(module: str, function: str) -> str | None:
    """The docstring (``__doc__``, uncleaned) of the top-level function ``function`` in the source of
    ``module``, read without importing the module; None when the source or the docstring is not there.

    Only the function is parsed, from its ``def`` to the next two blank lines (the end of a top-level
    definition in formatted code, ``ruff format``): the whole of a long module takes ten times longer."""
    import ast

    spec = importlib.util.find_spec(module)
    if spec is None or spec.origin is None or not spec.origin.endswith(".py"):
        return None
    try:
        source = Path(spec.origin).read_text(encoding="utf-8")
    except (OSError, ValueError):
        return None
    start = source.find(f"\ndef {function}(") + 1
    end = source.find("\n\n\n", start)
    try:
        tree = ast.parse(source[start : end if end >= 0 else len(source)]) if start else None
    except (SyntaxError, ValueError):
        return None
    node = tree.body[0] if tree is not None and tree.body else None
    return ast.get_docstring(node, clean=False) if isinstance(node, ast.FunctionDef) else None
