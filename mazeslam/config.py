"""Parameters as small dataclasses, loadable from TOML files in ``configs/``.

Every parameter has a default in code (the e-puck and the exercise); a TOML file overrides only the
keys it names. A key the dataclass does not know is an error that names the file, the section and
the key, so a typo never silently falls back to a default.
"""

from __future__ import annotations

import dataclasses
import enum
import math
import tomllib
import typing
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np

if TYPE_CHECKING:
    from _typeshed import DataclassInstance

T = TypeVar("T", bound="DataclassInstance")


class ConfigError(ValueError):
    """A configuration file or mapping that cannot be turned into parameters."""


def from_mapping(cls: type[T], mapping: dict[str, Any], where: str = "config") -> T:
    """Build dataclass ``cls`` from ``mapping``, recursing into fields that are dataclasses.

    ``where`` names the origin in error messages (e.g. ``"configs/sim.toml [laser]"``).
    """
    if not isinstance(mapping, dict):
        raise ConfigError(f"{where}: expected a table of parameters, got {type(mapping).__name__}")
    fields = {f.name: f for f in dataclasses.fields(cls)}
    unknown = sorted(set(mapping) - set(fields))
    if unknown:
        raise ConfigError(
            f"{where}: unknown parameter(s) {', '.join(unknown)}; known: {', '.join(sorted(fields))}"
        )
    hints = typing.get_type_hints(cls)
    values = {}
    for name, value in mapping.items():
        kind = hints.get(name)
        if isinstance(kind, type) and dataclasses.is_dataclass(kind):
            values[name] = from_mapping(kind, value, f"{where} [{name}]")
        else:
            values[name] = _coerce(kind, name, value, where)
    try:
        return cls(**values)
    except (TypeError, ValueError) as error:
        raise ConfigError(f"{where}: {error}") from error


def _coerce(kind, name: str, value, where: str):
    """``value`` as the option type ``kind`` where that is an Enum (TOML and the command line give
    its value); any other value unchanged (the dataclass checks it)."""
    if not (isinstance(kind, type) and issubclass(kind, enum.Enum)):
        return value
    try:
        return kind(value)
    except ValueError as error:
        choices = ", ".join(repr(member.value) for member in kind)
        raise ConfigError(f"{where}: {name} must be one of {choices}, got {value!r}") from error


def load_toml(cls: type[T], path: str | Path) -> T:
    """Read a TOML file into dataclass ``cls`` (sections map to nested dataclass fields)."""
    path = Path(path)
    try:
        with path.open("rb") as handle:
            mapping = tomllib.load(handle)
    except FileNotFoundError as error:
        raise ConfigError(f"{path}: config file not found") from error
    except tomllib.TOMLDecodeError as error:
        raise ConfigError(f"{path}: not valid TOML: {error}") from error
    return from_mapping(cls, mapping, str(path))


def with_changes(params: T, **changes) -> T:
    """``params`` (a frozen dataclass) with the given fields replaced; a change of None keeps the
    field (an option the user did not give). The one merge of command-line options into settings.
    A value the dataclass refuses raises ``ConfigError`` naming the field(s) changed."""
    hints = typing.get_type_hints(type(params))
    given = {name: _coerce(hints.get(name), name, value, type(params).__name__)
             for name, value in changes.items() if value is not None}
    if not given:
        return params
    try:
        return dataclasses.replace(params, **given)
    except (TypeError, ValueError) as error:
        raise ConfigError(f"{', '.join(sorted(given))}: {error}") from error


def to_mapping(params) -> dict[str, Any]:
    """The dataclass ``params`` as a plain (JSON/TOML-ready) nested dict."""
    return dataclasses.asdict(params)


def jsonable(value):
    """``value`` ready for strict JSON (``json.dumps(..., allow_nan=False)``): dicts, lists and
    tuples recursed, numpy arrays and scalars as Python values, and non-finite numbers (an infinite
    limit: no limit; an undefined statistic) as null."""
    if isinstance(value, dict):
        return {key: jsonable(item) for key, item in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [jsonable(item) for item in value]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def require(condition: bool, message: str) -> None:
    """Raise ValueError(message) unless ``condition``: the parameter checks of ``__post_init__``."""
    if not condition:
        raise ValueError(message)
