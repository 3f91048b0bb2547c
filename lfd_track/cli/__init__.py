"""The ``lfd-track`` command line: one module per command, each turning its arguments into a
config and calling the library (``demo``, ``sample-data``, ``evolve``, ``export``, ``drive``,
``benchmark``, ``evaluate``, ``study``, ``teach``, ``hardware``); :mod:`.parser` holds the parser
and :func:`main`, :mod:`.types` the argument types and exit codes, :mod:`.outputs` the checks of
output names.

Loaded on first use, so that ``python -m lfd_track.cli.hardware`` runs one command module alone.
"""

from __future__ import annotations

import importlib
from typing import Any

_LAZY = {
    "main": ".parser",
    "build_parser": ".parser",
    "EXIT_CODES": ".types",
    "EXIT_OK": ".types",
    "EXIT_ERROR": ".types",
    "EXIT_USAGE": ".types",
    "EXIT_INTERRUPTED": ".types",
    "EXIT_TERMINATED": ".types",
}

__all__ = sorted(_LAZY)


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'lfd_track.cli' has no attribute {name!r}")
    return getattr(importlib.import_module(module, __name__), name)
