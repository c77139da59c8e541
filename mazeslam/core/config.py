"""Parameters as small dataclasses, loadable from TOML files in ``configs/``.

Every parameter has a default in code (the e-puck and the exercise); a TOML file overrides only the
keys it names. A key the dataclass does not know is an error that names the file, the section and
the key, so a typo never silently falls back to a default.

Settings are checked once, where they come in (``from_mapping``/``load_toml`` for files,
``with_settings`` for the command line, code and sweeps): first their type from the dataclass's field
annotations (``int``, ``float``, ``bool``, ``str``, Enums, tuples, dicts, ``X | None``) - no bool
for a number, no fraction for an integer, no text for a number, no nan, no infinity except where the
default is infinite (no limit), no magnitude beyond ``MAX_FLOAT`` - then their ranges in each
class's ``__post_init__``. A refused value raises ``ConfigError`` naming ``file: [section] key``,
the value and the reason.
"""

from __future__ import annotations

import dataclasses
import enum
import gzip
import math
import tomllib
import types
import typing
import zlib
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np

if TYPE_CHECKING:
    from _typeshed import DataclassInstance

T = TypeVar("T", bound="DataclassInstance")


class ConfigError(ValueError):
    """A configuration file or mapping that cannot be turned into parameters."""


class InputError(ValueError):
    """An input file that cannot be read (missing, a folder, unreadable, not text, a broken gzip
    stream); the message names the file."""


#: Largest magnitude of a float setting: no length, time, angle or noise of this project comes near
#: it, and its square still fits a float.
MAX_FLOAT = 1e9
#: Integer settings fit 64 bits.
MAX_INT = 2**63 - 1


def read_text(path: str | Path, what: str = "file") -> str:
    """The text of ``path`` (UTF-8, or gzip-compressed UTF-8 when it starts with the gzip magic);
    every I/O, decompression and decoding error as one ``InputError`` naming the file. A missing
    file raises ``FileNotFoundError`` with the same kind of message."""
    path = Path(path)
    try:
        data = path.read_bytes()
        if data[:2] == b"\x1f\x8b":
            data = gzip.decompress(data)
        return data.decode("utf-8")
    except FileNotFoundError as error:
        raise FileNotFoundError(f"{path}: {what} not found") from error
    except IsADirectoryError as error:
        raise InputError(f"{path}: is a folder, not a {what}") from error
    except OSError as error:  # PermissionError, BadGzipFile (an OSError), ...
        raise InputError(f"{path}: cannot read the {what}: {error.strerror or error}") from error
    except EOFError as error:
        raise InputError(f"{path}: the gzip stream is cut off (truncated file)") from error
    except zlib.error as error:
        raise InputError(f"{path}: broken gzip data ({error})") from error
    except UnicodeDecodeError as error:
        line = error.object[: error.start].count(b"\n") + 1
        raise InputError(
            f"{path}:{line}: not a text {what} (not UTF-8: {error.reason} at byte {error.start})"
        ) from error


def from_mapping(cls: type[T], mapping: dict[str, Any], where: str = "config") -> T:
    """Build dataclass ``cls`` from ``mapping``, recursing into fields that are dataclasses.

    ``where`` names the origin in error messages (e.g. ``"configs/sim.toml [laser]"``).
    """
    if not isinstance(mapping, dict):
        raise ConfigError(f"{where}: expected a table of parameters, got {type(mapping).__name__}")
    fields = {f.name: f for f in dataclasses.fields(cls)}
    unknown = sorted(set(mapping) - set(fields))
    if unknown:
        raise ConfigError(f"{where}: unknown parameter(s) {', '.join(unknown)}; known: {', '.join(sorted(fields))}")
    hints = typing.get_type_hints(cls)
    values = {}
    for name, value in mapping.items():
        kind = hints.get(name)
        if isinstance(kind, type) and dataclasses.is_dataclass(kind):
            values[name] = from_mapping(kind, value, f"{where} [{name}]")
        else:
            values[name] = check_setting(kind, name, value, where, _allows_infinity(fields[name]))
    try:
        return cls(**values)
    except (TypeError, ValueError) as error:
        raise ConfigError(f"{where}: {error}") from error


def _allows_infinity(field: dataclasses.Field) -> bool:
    """A float setting may be infinite where its default is (an infinite limit: no limit)."""
    return isinstance(field.default, float) and math.isinf(field.default)


def _shown(value) -> str:
    """``value`` for a message, cut short (a setting can be a long list)."""
    text = repr(value)
    if isinstance(value, bool):
        text = "true" if value else "false"
    return text if len(text) <= 40 else text[:37] + "..."


class _Refused(ValueError):
    """Why a value does not fit a setting's type (``check_setting`` adds where and which)."""


def check_setting(kind, name: str, value, where: str = "config", allow_infinity: bool = False):
    """``value`` checked against the setting ``name``'s annotation ``kind`` (and converted: an int for
    a float, a list for a tuple, a value for an Enum); ``ConfigError`` naming ``where``, the key,
    the value and the reason when it does not fit. Ranges are the dataclasses' ``__post_init__``'s."""
    try:
        return _typed(kind, value, allow_infinity)
    except _Refused as error:
        raise ConfigError(f"{where}: {name} = {_shown(value)}: {error}") from None


def _typed(kind, value, allow_infinity: bool = False):
    origin, args = typing.get_origin(kind), typing.get_args(kind)
    if kind is None or kind is typing.Any:
        return value
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        options = [arg for arg in args if arg is not type(None)]
        # Exact types first (an int for ``int | str``), then conversions (an int for a float).
        ordered = sorted(options, key=lambda arg: not (isinstance(arg, type) and type(value) is arg))
        reasons = []
        for option in ordered:
            try:
                return _typed(option, value, allow_infinity)
            except _Refused as error:
                reasons.append(str(error))
        raise _Refused(" or ".join(dict.fromkeys(reasons)))
    if kind is bool:
        if not isinstance(value, bool):
            raise _Refused("must be true or false")
        return value
    if kind is int:
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
            raise _Refused("must be an integer" + (" (no fraction)" if isinstance(value, float) else ""))
        if abs(int(value)) > MAX_INT:
            raise _Refused(f"must be an integer within +-{MAX_INT} (64 bits)")
        return int(value)
    if kind is float:
        if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
            raise _Refused("must be a number")
        try:
            number = float(value)
        except OverflowError:  # an integer beyond any float
            raise _Refused(f"is out of range: a setting's magnitude is at most {MAX_FLOAT:g}") from None
        if math.isnan(number):
            raise _Refused("must be a number, not nan")
        if math.isinf(number):
            if allow_infinity and number > 0 and isinstance(value, float):
                return number
            raise _Refused("must be finite" + (" (or inf: no limit)" if allow_infinity else ""))
        if abs(number) > MAX_FLOAT:
            raise _Refused(f"is out of range: a setting's magnitude is at most {MAX_FLOAT:g}")
        return number
    if kind is str:
        if not isinstance(value, str):
            raise _Refused("must be a text")
        return value
    if isinstance(kind, type) and issubclass(kind, enum.Enum):
        try:
            return kind(value)
        except ValueError:
            raise _Refused(f"must be one of {', '.join(repr(member.value) for member in kind)}") from None
    if kind is tuple or origin is tuple or kind is list or origin is list:
        if not isinstance(value, (list, tuple)):
            raise _Refused("must be a list")
        if args and args[-1] is not Ellipsis and len(args) != len(value):
            raise _Refused(f"must be a list of {len(args)} values")
        if not args:  # a bare ``tuple``: the settings' are lists of numbers
            kinds = [float] * len(value)
        elif args[-1] is Ellipsis:
            kinds = [args[0]] * len(value)
        else:
            kinds = list(args)
        items = []
        for k, (item_kind, item) in enumerate(zip(kinds, value)):
            try:
                items.append(_typed(item_kind, item))
            except _Refused as error:
                raise _Refused(f"item {k + 1} ({_shown(item)}) {error}") from None
        return list(items) if (kind is list or origin is list) else tuple(items)
    if kind is dict or origin is dict:
        if not isinstance(value, dict):
            raise _Refused("must be a table")
        key_kind, value_kind = args if len(args) == 2 else (None, None)
        checked = {}
        for key, item in value.items():
            try:
                checked[_typed(key_kind, key)] = _typed(value_kind, item)
            except _Refused as error:
                raise _Refused(f"entry {key!r} ({_shown(item)}) {error}") from None
        return checked
    if isinstance(kind, type) and dataclasses.is_dataclass(kind):
        if not isinstance(value, kind):
            raise _Refused(f"must be a {kind.__name__} table")
        return value
    return value


def load_toml(cls: type[T], path: str | Path) -> T:
    """Read a TOML file into dataclass ``cls`` (sections map to nested dataclass fields); a file
    with ``extends = "other.toml"`` starts from that file's settings (``read_settings``)."""
    mapping, chain = read_settings(Path(path))
    return from_mapping(cls, mapping, _described(chain))


def load_toml_section(cls: type[T], path: str | Path, section: str) -> T:
    """``cls`` from the table ``[section]`` of the TOML file ``path`` (one section of a file of
    several, e.g. a slam config's ``[corners]``), or from the whole file when it has no such table."""
    mapping, chain = read_settings(Path(path))
    if not isinstance(mapping.get(section), dict):
        return from_mapping(cls, mapping, _described(chain))
    return from_mapping(cls, mapping[section], f"{_described(chain)} [{section}]")


def _described(chain: list[Path]) -> str:
    """The files ``read_settings`` read, for messages: the first, and the ones it extends."""
    if len(chain) == 1:
        return str(chain[0])
    return f"{chain[0]} (extending {', '.join(str(p) for p in chain[1:])})"


#: The key by which a config file names another (a path relative to it) whose settings it starts from.
EXTENDS = "extends"


def read_settings(path: Path, chain: tuple[Path, ...] = ()) -> tuple[dict[str, Any], list[Path]]:
    """The TOML document at ``path`` as a mapping, merged over the document it ``extends`` (if any,
    recursively): its tables merge key by key into the base's, its values replace the base's. Also
    the files read, ``path`` first. ``ConfigError`` naming the file for a missing, unreadable or
    invalid file, or a cycle of ``extends``."""
    if path.resolve() in chain:
        raise ConfigError(f"{path}: extends itself (through {', '.join(str(p) for p in chain)})")
    try:
        mapping = tomllib.loads(read_text(path, "config file"))
    except (FileNotFoundError, InputError) as error:
        raise ConfigError(str(error)) from error
    except tomllib.TOMLDecodeError as error:
        raise ConfigError(f"{path}: not valid TOML: {error}") from error
    base = mapping.pop(EXTENDS, None)
    if base is None:
        return mapping, [path]
    if not isinstance(base, str):
        raise ConfigError(f"{path}: {EXTENDS} = {base!r}: must be the path of another config file")
    base_mapping, files = read_settings(path.parent / base, (*chain, path.resolve()))
    return _merged(base_mapping, mapping), [path, *files]


def _merged(base: dict[str, Any], over: dict[str, Any]) -> dict[str, Any]:
    """``over`` merged into ``base``: tables key by key, anything else replaced."""
    merged = dict(base)
    for key, value in over.items():
        if isinstance(value, dict) and isinstance(merged.get(key), dict):
            merged[key] = _merged(merged[key], value)
        else:
            merged[key] = value
    return merged


def with_changes(params: T, **changes) -> T:
    """``params`` (a frozen dataclass) with the given fields replaced; a change of None keeps the
    field (an option the user did not give). The one merge of command-line options into settings.
    A value the dataclass refuses raises ``ConfigError`` naming the field(s) changed."""
    hints = typing.get_type_hints(type(params))
    fields = {f.name: f for f in dataclasses.fields(params)}
    unknown = sorted(set(changes) - set(fields))
    if unknown:
        raise ConfigError(f"{type(params).__name__}: unknown parameter(s) {', '.join(unknown)}")
    given = {
        name: check_setting(hints.get(name), name, value, type(params).__name__, _allows_infinity(fields[name]))
        for name, value in changes.items()
        if value is not None
    }
    if not given:
        return params
    try:
        return dataclasses.replace(params, **given)
    except (TypeError, ValueError) as error:
        raise ConfigError(f"{', '.join(sorted(given))}: {error}") from error


def with_settings(params: T, changes: dict[str, Any]) -> T:
    """``params`` (a frozen dataclass, nested) with the settings ``changes`` names by dotted path
    (``{"grid.particles": 10, "maze.rows": 5}``) replaced; a value of None keeps the setting (an
    option the user did not give). The one merge of overrides into settings, for the command line,
    the Python API and sweeps: each value is checked by ``with_changes``; a name the settings do not
    have raises ``ConfigError`` naming it and the known ones."""
    names = {f.name for f in dataclasses.fields(params)}
    direct: dict[str, Any] = {}
    nested: dict[str, dict[str, Any]] = {}
    for place, value in changes.items():
        if value is None:
            continue
        head, _, rest = place.partition(".")
        if head not in names:
            raise ConfigError(f"no setting {head!r} in {type(params).__name__} (known: {', '.join(sorted(names))})")
        if rest:
            nested.setdefault(head, {})[rest] = value
        else:
            direct[head] = value
    params = with_changes(params, **direct)
    if nested:
        inner = {head: with_settings(getattr(params, head), values) for head, values in nested.items()}
        params = dataclasses.replace(params, **inner)
    return params


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
