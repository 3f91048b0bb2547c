"""The learning methods by name: one :class:`Method` entry per method.

An entry says everything the benchmark, the study files and the command line need to know of a
method: its name, its learn function over one :class:`~lfd_track.methods.common.MethodContext`,
its settings class and the name of their table (``[conditions.<table>]`` in a study file, the
``<table>`` key of a results.json's ``config``), what it can learn from (``takes_views``,
``policy_kinds``), one phrase for ``--help`` and any flags of its own. The built-in methods are
registered by :mod:`lfd_track.methods`; :func:`register_method` adds one from anywhere.
"""

from __future__ import annotations

import argparse
import re
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

from .common import Learned, MethodContext

POLICY_KINDS_MLP = ("mlp-sigmoid",)
"""The paper's network only (the ``policy_kinds`` of most methods)."""
_NAME = re.compile(r"^[a-z][a-z0-9-]{0,31}$")
_TABLE = re.compile(r"^[a-z][a-z0-9_]{0,31}$")


@dataclass(frozen=True)
class MethodFlags:
    """Command-line flags of one method (``lfd-track benchmark``)."""

    add: Callable[[argparse.ArgumentParser], None]
    """Add the flags to the command's parser (their defaults must mean "not given")."""
    given: Callable[[argparse.Namespace], list[str]]
    """The flags the user gave; refused in one line unless the method is chosen."""
    settings: Callable[[argparse.Namespace], Any]
    """The method's settings from the flags (called when the method is chosen)."""


@dataclass(frozen=True)
class Method:
    """One learning method."""

    name: str
    """What ``method`` says in a study file, ``--method`` on the command line and ``method`` in
    results.json (lower-case letters, digits and '-')."""
    learn: Callable[[MethodContext], Learned]
    """Learns one repetition's controller (its files go to ``context.rep_dir``)."""
    settings: type[Any] | None = None
    """Its settings class: a frozen dataclass whose every field has a default, with
    ``to_dict()`` and the class method ``from_dict(data)`` (as :class:`~lfd_track.core.config.
    DictConfig` gives them); None if it has none."""
    table: str = ""
    """Name of its settings table (default: the name with '-' as '_')."""
    takes_views: bool = False
    """Learns after one simulated demonstration, so can learn from its shifted and turned views
    (``shifted_views``) and from saved cases after its own (``extra_cases``)."""
    policy_kinds: tuple[str, ...] = POLICY_KINDS_MLP
    """The networks it trains (``policy_kind``)."""
    summary: str = ""
    """What a repetition does, in a few words (``lfd-track benchmark --help``)."""
    flags: MethodFlags | None = None
    """Its own command-line flags, if any."""

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not _NAME.match(self.name):
            raise ValueError(
                f"a method's name is lower-case letters, digits and '-', got {self.name!r}"
            )
        if not callable(self.learn):
            raise ValueError(f"method '{self.name}': learn must be a function of a MethodContext")
        table = self.table or self.name.replace("-", "_")
        if not _TABLE.match(table):
            raise ValueError(
                f"method '{self.name}': a table name is lower-case letters, digits and '_',"
                f" got {table!r}"
            )
        object.__setattr__(self, "table", table)
        if self.settings is not None:
            for needed in ("to_dict", "from_dict"):
                if not callable(getattr(self.settings, needed, None)):
                    raise ValueError(f"method '{self.name}': its settings class has no {needed}")
        if isinstance(self.policy_kinds, str) or not self.policy_kinds:
            raise ValueError(f"method '{self.name}': policy_kinds must be a tuple of kinds")
        object.__setattr__(self, "policy_kinds", tuple(self.policy_kinds))

    def default_settings(self) -> Any:
        """Its settings with every default (None without a settings class)."""
        return None if self.settings is None else self.settings()


_METHODS: dict[str, Method] = {}


def register_method(method: Method) -> Method:
    """Add ``method``; a name or table another method has is refused (``ValueError``)."""
    if not isinstance(method, Method):
        raise TypeError(f"register_method takes a Method, got {type(method).__name__}")
    if method.name in _METHODS:
        raise ValueError(f"a method named '{method.name}' is registered already")
    for other in _METHODS.values():
        if other.table == method.table:
            raise ValueError(
                f"method '{method.name}': the settings table '{method.table}' is method"
                f" '{other.name}'s"
            )
    _METHODS[method.name] = method
    return method


def unregister_method(name: str) -> Method:
    """Remove the method ``name`` and return its entry (``KeyError`` if there is none)."""
    return _METHODS.pop(name)


@contextmanager
def registered(method: Method) -> Iterator[Method]:
    """``method`` registered for the ``with`` block, unregistered after it."""
    register_method(method)
    try:
        yield method
    finally:
        _METHODS.pop(method.name, None)


def method_names() -> tuple[str, ...]:
    """The registered methods' names, in the order they were registered."""
    return tuple(_METHODS)


def methods() -> tuple[Method, ...]:
    """The registered methods, in the order they were registered."""
    return tuple(_METHODS.values())


def get_method(name: str) -> Method:
    """The method ``name``; an unknown name raises ``ValueError`` naming the known ones."""
    try:
        return _METHODS[name]
    except (KeyError, TypeError):
        raise ValueError(f"unknown method '{name}' (choose from {', '.join(_METHODS)})") from None


def method_of_table(table: str) -> Method | None:
    """The method whose settings table is ``table``, or None."""
    return next((m for m in _METHODS.values() if m.settings and m.table == table), None)
