"""The ``mazeslam`` command line: the group, its error handling and its commands, one sub-command
per stage (see ``mazeslam --help``).

Built on click: typed options, ``--help`` for every command and clean error reporting without
hand-written argument parsing. Each command lives in its own module of ``mazeslam.cli``, named after
it, and is imported only when it runs (``mazeslam.cli.lazy``): start-up stays short.
"""

from __future__ import annotations

import click

from mazeslam.cli.lazy import LazyCommand, LazyGroup
from mazeslam.core.config import ConfigError, InputError
from mazeslam.core.outputs import OutputError
from mazeslam.data import log
from mazeslam.robot.interface import RobotError


@click.group(cls=LazyGroup)
@click.version_option(package_name="mazeslam")
def main():
    """Particle-filter SLAM (FastSLAM) for a small differential-drive robot in a maze."""


#: Each command: its name, its module and the click command's name there, in ``--help``'s order.
COMMANDS = (
    ("simulate", "mazeslam.cli.simulate", "simulate"),
    ("info", "mazeslam.cli.info", "info"),
    ("corners", "mazeslam.cli.corners", "corners"),
    ("slam", "mazeslam.cli.slam", "slam"),
    ("smooth", "mazeslam.cli.smooth", "smooth"),
    ("record", "mazeslam.cli.record", "record"),
    ("sweep", "mazeslam.cli.sweep", "sweep"),
    ("calibrate", "mazeslam.cli.calibrate", "calibrate"),
    ("odometry-noise", "mazeslam.cli.odometry_noise", "odometry_noise"),
    ("report", "mazeslam.cli.report", "report"),
    ("import", "mazeslam.cli.imports", "import_group"),
    ("demo", "mazeslam.cli.demo", "demo"),
    ("relations", "mazeslam.cli.relations", "relations"),
)
for _name, _module, _attribute in COMMANDS:
    main.add_command(LazyCommand(_name, _module, _attribute))


#: The errors the command line reports as one line ``error: <message>`` (no traceback): bad input
#: (a log, a config, a maze, a sweep file; a setting out of range), an output that cannot be
#: written, a robot that went away, and any file the system refuses (OSError).
KNOWN_ERRORS = (log.LogFormatError, ConfigError, InputError, OutputError, ValueError, RobotError, OSError)


def exit_status(error: BaseException) -> int:
    """The exit status of a ``KNOWN_ERRORS`` error: 2 for bad input, 1 for an output or the system."""
    return (
        1
        if isinstance(error, (OutputError, PermissionError))
        or (isinstance(error, OSError) and not isinstance(error, FileNotFoundError))
        else 2
    )


def run():
    """Entry point: turn known errors into a one-line message and exit status 2 (bad input) or 1;
    SIGTERM and SIGINT stop the command cleanly (its children and temporary outputs go with it),
    saying so, with exit status 143 or 130."""
    from mazeslam.cli.side_process import Interrupted, stop_on_signals

    try:
        with stop_on_signals():
            main(standalone_mode=True)
    except Interrupted as stop:
        click.echo(f"interrupted ({stop.signal_name})", err=True)
        raise
    except KNOWN_ERRORS as error:
        click.echo(f"error: {error}", err=True)
        raise SystemExit(exit_status(error)) from error
