"""Reading older files through one migration function per schema step.

A file format of ours carries ``schema``, an integer that grows by one whenever what the file
holds changes. Its module keeps the current number and the list of its steps: step ``k`` turns a
schema-``k`` dict into a schema-``k + 1`` dict (and sets ``schema`` to ``k + 1``). A reader
passes what it parsed to :func:`migrate` and from then on reads the current shape only; the
writer always writes the current shape, in full. A JSON file format holds its name, steps and
largest size in one :class:`VersionedJson`, whose ``migrate`` and ``read`` its module exports.
"""

from __future__ import annotations

import copy
import json
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..errors import FileFormatError, first_line
from .files import read_regular_text, reject_constant

Step = Callable[[dict[str, Any]], dict[str, Any]]
"""One schema step: a schema-k dict (a private copy, free to change) to a schema-k+1 dict."""


def migrate(
    data: dict[str, Any], source: object, *, what: str, steps: Sequence[Step]
) -> dict[str, Any]:
    """``data`` (parsed from ``source``) brought to the current schema, ``len(steps) + 1``.

    A dict without ``schema`` is schema 1 (files and dicts written before it was counted).
    ``data`` is returned as it is when current, else migrated on a copy (never changed).
    A ``schema`` that is not an integer from 1 or is newer than the current one, or a step's
    ``ValueError``, raises :class:`~lfd_track.errors.FileFormatError` in one line naming
    ``source`` (``what`` names the kind of file).
    """
    current = len(steps) + 1
    version = data.get("schema", 1)
    if isinstance(version, bool) or not isinstance(version, int) or version < 1:
        raise FileFormatError(source, f"{what} schema must be an integer >= 1, got {version!r}")
    if version > current:
        raise FileFormatError(
            source,
            f"{what} schema {version} is newer than this lfd-track reads ({current});"
            " upgrade lfd-track to read it",
        )
    if version == current:
        return data
    out = copy.deepcopy(data)
    try:
        for step in steps[version - 1 :]:
            out = step(out)
    except FileFormatError:
        raise
    except ValueError as exc:  # a setting an older file holds that no current one can mean
        raise FileFormatError(
            source, f"{what} of schema {version} cannot be read: {first_line(exc)}"
        ) from None
    return out


def read_versioned(
    path: str | Path, *, what: str, steps: Sequence[Step], max_bytes: int
) -> dict[str, Any]:
    """The JSON object in the regular file ``path`` (at most ``max_bytes``), migrated by
    ``steps`` to the current schema (:func:`migrate`).

    An unreadable file, one that is not a JSON object (NaN and Infinity refused), or one of a
    newer schema raises :class:`~lfd_track.errors.FileFormatError` in one line naming it.
    """
    text = read_regular_text(path, max_bytes, what)
    try:
        data = json.loads(text, parse_constant=reject_constant)
    except RecursionError:
        raise FileFormatError(path, f"unreadable {what} (JSON nested too deeply)") from None
    except ValueError as exc:  # not JSON, NaN, or an integer of thousands of digits
        raise FileFormatError(path, f"unreadable {what} ({first_line(exc)})") from None
    if not isinstance(data, dict):
        raise FileFormatError(path, f"unreadable {what} (not a JSON object)")
    return migrate(data, path, what=what, steps=steps)


@dataclass(frozen=True)
class VersionedJson:
    """A JSON file format of ours: what messages call it, its schema steps, its largest file."""

    what: str
    """The kind of file, as an error names it (``"results"``)."""
    steps: tuple[Step, ...]
    """Step k turns a schema-k dict into schema k + 1."""
    max_bytes: int
    """Largest file :meth:`read` reads [bytes]."""

    @property
    def current(self) -> int:
        """The schema this version writes, ``len(steps) + 1``."""
        return len(self.steps) + 1

    def migrate(self, data: dict[str, Any], source: object) -> dict[str, Any]:
        """A dict of this format (parsed from ``source``) in the current schema; ``data`` is kept.

        Raises :class:`~lfd_track.errors.FileFormatError` naming ``source`` if its schema is not
        an integer from 1 or is newer than :attr:`current` (:func:`migrate`).
        """
        return migrate(data, source, what=self.what, steps=self.steps)

    def read(self, path: str | Path, max_bytes: int | None = None) -> dict[str, Any]:
        """The file at ``path`` (at most ``max_bytes``, by default :attr:`max_bytes`), parsed and
        migrated to the current schema (:func:`read_versioned`: errors in one line naming it)."""
        limit = self.max_bytes if max_bytes is None else max_bytes
        return read_versioned(path, what=self.what, steps=self.steps, max_bytes=limit)
