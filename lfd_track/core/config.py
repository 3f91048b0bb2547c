"""Build frozen config dataclasses from TOML tables, rejecting unknown keys and bad values."""

from __future__ import annotations

import dataclasses
import math
import tomllib
import types
import typing
from pathlib import Path
from typing import Any, ClassVar, Self, TypeVar

from ..errors import FileFormatError
from ..utils.files import read_regular_text

T = TypeVar("T")


def _check_value(value: Any, annotation: Any, where: str, path: Path | str) -> Any:
    origin = typing.get_origin(annotation)
    if origin in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(annotation) if a is not type(None)]
        if value is None:
            return None
        annotation = args[0]
        origin = typing.get_origin(annotation)
    if annotation is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise FileFormatError(path, f"'{where}' must be a number, got {value!r}")
        try:
            number = float(value)
        except OverflowError:  # an integer beyond any float
            number = math.inf
        if not math.isfinite(number):
            raise FileFormatError(path, f"'{where}' must be finite, got {value!r}")
        return number
    if annotation is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise FileFormatError(path, f"'{where}' must be an integer, got {value!r}")
        return value
    if annotation is bool:
        if not isinstance(value, bool):
            raise FileFormatError(path, f"'{where}' must be true or false, got {value!r}")
        return value
    if annotation is str:
        if not isinstance(value, str):
            raise FileFormatError(path, f"'{where}' must be a string, got {value!r}")
        return value
    if origin is tuple:
        if not isinstance(value, (list, tuple)):
            raise FileFormatError(path, f"'{where}' must be a list, got {value!r}")
        entries = typing.get_args(annotation)
        if len(entries) == 2 and entries[1] is Ellipsis:
            return tuple(_check_value(v, entries[0], where, path) for v in value)
        if len(entries) != len(value):
            raise FileFormatError(
                path, f"'{where}' must have {len(entries)} entries, got {len(value)}"
            )
        return tuple(_check_value(v, a, where, path) for v, a in zip(value, entries, strict=True))
    return value


def dataclass_from_table(cls: type[T], table: dict[str, Any], where: str, path: Path | str) -> T:
    """Make ``cls`` from a TOML table; unknown keys, wrong types and NaN fail naming the file.

    Missing keys take the dataclass defaults. ``where`` names the table (e.g. ``"camera"``).
    Validation beyond types belongs in the dataclass's ``__post_init__`` raising ``ValueError``.
    """
    if not isinstance(table, dict):
        raise FileFormatError(path, f"[{where}] must be a table")
    hints = typing.get_type_hints(cls)
    fields = {f.name for f in dataclasses.fields(cls)}  # type: ignore[arg-type]
    unknown = sorted(set(table) - fields)
    if unknown:
        raise FileFormatError(path, f"unknown key '{where}.{unknown[0]}'")
    kwargs = {k: _check_value(v, hints[k], f"{where}.{k}", path) for k, v in table.items()}
    try:
        return cls(**kwargs)
    except (TypeError, ValueError) as exc:
        raise FileFormatError(path, f"[{where}] {exc}") from None


def config_from_dict(cls: type[T], data: Any, what: str) -> T:
    """Rebuild the frozen config ``cls`` from its ``dataclasses.asdict`` form.

    Nested config fields (a field whose value is itself a dataclass, e.g. an intervention rule)
    are rebuilt the same way. Unknown keys and bad values raise ``ValueError`` naming ``what``.
    """
    if not isinstance(data, dict):
        raise ValueError(f"{what} settings must be an object")
    fields = {f.name: f for f in dataclasses.fields(cls)}  # type: ignore[arg-type]
    unknown = sorted(set(data) - set(fields))
    if unknown:
        raise ValueError(f"unknown {what} setting '{unknown[0]}'")
    values = dict(data)
    for name, value in data.items():
        field = fields[name]
        factory = field.default_factory
        default = factory() if factory is not dataclasses.MISSING else field.default
        if dataclasses.is_dataclass(default) and isinstance(value, dict):
            values[name] = config_from_dict(type(default), value, what)
    try:
        return cls(**values)
    except TypeError as exc:
        raise ValueError(f"{what}: {exc}") from None


class DictConfig:
    """Mixin for frozen settings dataclasses: ``to_dict`` and its checked inverse ``from_dict``.

    A subclass names itself in error messages with ``settings_name`` (e.g. ``"GA"``).
    """

    settings_name: ClassVar[str] = "config"

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-friendly dict of the fields (nested settings as dicts)."""
        return dataclasses.asdict(self)  # type: ignore[call-overload]

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Self:
        """Inverse of :meth:`to_dict`; unknown keys or bad values raise ``ValueError``."""
        return config_from_dict(cls, data, cls.settings_name)


def read_toml(path: Path | str, *, max_bytes: int = 1 << 20, what: str = "TOML") -> dict[str, Any]:
    """Parse a TOML file; unreadable or malformed files fail with one line naming the file.

    Only regular files up to ``max_bytes`` are read (a FIFO or ``/dev/zero`` is refused, not
    waited on); ``what`` names the kind of file in messages.
    """
    text = read_regular_text(path, max_bytes, what)
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise FileFormatError(path, f"not valid TOML ({exc})") from None
    except RecursionError:
        raise FileFormatError(path, "TOML nested too deeply") from None
    except ValueError as exc:  # e.g. an integer with thousands of digits
        raise FileFormatError(path, f"not valid TOML ({str(exc).splitlines()[0]})") from None
