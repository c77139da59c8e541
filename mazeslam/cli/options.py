"""Click option types that check a setting where it comes in: its type, finiteness, range and size;
and the beam-geometry options that every command reading scans shares.

``click.FloatRange`` lets nan through (every comparison with nan is false) and infinity when it has
no upper bound; these types refuse both, and refuse sizes that would take more memory than any
machine has (``mazeslam.core.limits``), saying so. Click names the option in the message
("Invalid value for '--particles': ...").
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING

import click

from mazeslam.core import limits
from mazeslam.core.config import MAX_FLOAT, InputError

if TYPE_CHECKING:
    from mazeslam.core.beams import SensorOverrides


class Number(click.ParamType):
    """A finite float (or an int with ``integer=True``) in ``[low, high]`` (``low_open``: excluded),
    refused with ``problem(value)``'s reason when that returns one."""

    def __init__(
        self,
        low: float | None = None,
        high: float | None = None,
        low_open: bool = False,
        integer: bool = False,
        problem: Callable[[float], str | None] | None = None,
    ):
        self.low, self.high, self.low_open, self.integer, self.problem = low, high, low_open, integer, problem
        self.name = "integer" if integer else "float"

    def convert(self, value, param, ctx):
        if isinstance(value, bool):
            self.fail(f"{value!r} is not a number", param, ctx)
        if self.integer:
            try:
                number = value if isinstance(value, int) else int(str(value).strip(), 10)
            except ValueError:
                self.fail(f"{value!r} is not an integer", param, ctx)
        else:
            try:
                number = float(value)
            except (TypeError, ValueError):
                self.fail(f"{value!r} is not a number", param, ctx)
            if not math.isfinite(number):
                self.fail(f"{value!r} is not a finite number", param, ctx)
            if abs(number) > MAX_FLOAT:
                self.fail(f"{value!r} is out of range (magnitude at most {MAX_FLOAT:g})", param, ctx)
        low_fails = self.low is not None and (number <= self.low if self.low_open else number < self.low)
        if low_fails or (self.high is not None and number > self.high):
            self.fail(f"{value!r} is not in {self._range()}", param, ctx)
        if self.problem is not None:
            reason = self.problem(number)
            if reason:
                self.fail(reason, param, ctx)
        return number

    def _range(self) -> str:
        low = "" if self.low is None else f"{self._shown(self.low)}{' <' if self.low_open else ' <='} "
        high = "" if self.high is None else f" <= {self._shown(self.high)}"
        return f"the range {low}x{high}" if (low or high) else "range"

    def _shown(self, bound: float) -> str:
        return str(int(bound)) if self.integer else f"{bound:g}"

    def get_metavar(self, param, ctx=None):  # click 8.1 (param) and 8.2 (param, ctx)
        return "INTEGER" if self.integer else "FLOAT"


#: Any finite number (an angle, an offset).
FINITE = Number()
#: A positive finite number.
POSITIVE = Number(0, low_open=True)
#: Seconds of a run: positive, finite and at most ``limits.MAX_DURATION``.
DURATION = Number(0, limits.MAX_DURATION, low_open=True)
#: A seed: a non-negative 64-bit integer.
SEED = Number(0, limits.MAX_SEED, integer=True)
#: Particles of a filter, at most ``limits.MAX_PARTICLES`` (the message says the memory it would take).
PARTICLES = Number(1, integer=True, problem=lambda n: limits.particles_problem(int(n)))
#: Beams per scan (at least 2), at most ``limits.MAX_BEAMS``.
BEAMS = Number(2, integer=True, problem=lambda n: limits.beams_problem(int(n)))
#: Rows or columns of a maze (their product is checked against ``limits.MAX_MAZE_CELLS``).
MAZE_SIDE = Number(1, limits.MAX_MAZE_CELLS, integer=True)
#: A rate (Hz): positive, at most 1000.
RATE = Number(0, 1000, low_open=True)


def beam_geometry_options(function):
    """The options that override a log's beam geometry (for every command that reads scans)."""
    options = [
        click.option("--first-beam-angle", type=FINITE, help="Bearing of beam 0 in the robot frame [rad]."),
        click.option(
            "--beam-direction",
            type=click.Choice(["1", "-1"]),
            help="1: bearings grow counter-clockwise with the beam index; -1: clockwise.",
        ),
        click.option("--mount-x", type=FINITE, help="Sensor ahead of the wheel axle [m] (CAMERA_POS_DX)."),
    ]
    for option in reversed(options):
        function = option(function)
    return function


def geometry_overrides(first_beam_angle, beam_direction, mount_x) -> SensorOverrides:
    """The beam-geometry options as ``SensorOverrides`` (None: not given)."""
    from mazeslam.core.beams import SensorOverrides

    try:
        return SensorOverrides(
            first_beam_angle=first_beam_angle,
            mount_x=mount_x,
            direction=int(beam_direction) if beam_direction else None,
        )
    except ValueError as error:
        raise click.BadParameter(str(error), param_hint="--first-beam-angle/--mount-x") from error


@contextmanager
def course_log_expected(path: Path) -> Iterator[None]:
    """Meanwhile a file that is not a course log but a dataset's own log is refused in words that say
    how to import it (``mazeslam import carmen``), instead of the first line that is not a number."""
    from mazeslam.data import log

    try:
        yield
    except log.LogFormatError as error:
        if not _is_carmen(path):
            raise
        raise InputError(
            f"{path}: not a course log (a CARMEN log? run `mazeslam import carmen {path} --out "
            f"runs/{_stem(path)}.log`, then give that log)"
        ) from error


def _is_carmen(path: Path) -> bool:
    """``path`` reads as a CARMEN log (``mazeslam.data.carmen.is_carmen``); False when it cannot be read."""
    from mazeslam.data.carmen import is_carmen

    try:
        return is_carmen(path)
    except (OSError, ValueError, EOFError):
        return False


def _stem(path: Path) -> str:
    """``aces-corrected.log.gz`` -> ``aces-corrected``: the name without its suffixes."""
    return path.name.split(".")[0]
