"""``python -m mazeslam.cli``: the ``mazeslam`` command."""

from mazeslam.cli.main import run

run()
