"""The command line run in the test's process, as ``mazeslam.cli.main.run`` reports it."""

import traceback

from click.testing import CliRunner

from mazeslam.cli.main import KNOWN_ERRORS, exit_status, main


def cli(*args) -> tuple[int, str]:
    """(exit status, everything printed) of ``mazeslam ARGS``; a traceback fails the test."""
    result = CliRunner().invoke(main, [str(a) for a in args])
    error = result.exception
    if error is not None and not isinstance(error, SystemExit):
        trace = "".join(traceback.format_exception(error))
        assert isinstance(error, KNOWN_ERRORS), f"traceback for mazeslam {' '.join(map(str, args))}:\n{trace}"
        return exit_status(error), result.output + f"error: {error}\n"
    return result.exit_code, result.output
