"""The ``.lfdemo`` demonstration format: an append-only, crash-safe record log.

- :mod:`.model`: :class:`Demonstration`, a loaded file (read-only arrays and metadata);
- :mod:`.records`: the record layout (the file format, described there) and its encoding;
- :mod:`.checks`: the value checks a case passes when written and again when read;
- :mod:`.writer`: :class:`DemonstrationWriter` (case by case) and :func:`save_demonstration`;
- :mod:`.reader`: :func:`load_demonstration` (schemas 1-4, the road library replayed);
- :mod:`.recording`: recording a session safely under an output name (the commands' rules);
- :mod:`.sample`: the shipped sample demonstrations (``lfd-track sample-data``);
- :mod:`.minari`: demonstrations as Minari datasets and back (the ``minari`` extra; not imported
  here).
"""

from __future__ import annotations

from .model import Demonstration
from .reader import load_demonstration
from .records import (
    DEFAULT_BINS,
    FILE_EXTENSION,
    FORMAT_NAME,
    MAX_FILE_BYTES,
    MAX_MEMORY_INPUTS,
    MAX_ZERO_TAIL_BYTES,
    N_CHANNELS,
    N_VALUES,
    READABLE_SCHEMAS,
    SCHEMA_VERSION,
    SOURCES,
)
from .writer import DemonstrationWriter, save_demonstration

__all__ = [
    "DEFAULT_BINS",
    "FILE_EXTENSION",
    "FORMAT_NAME",
    "MAX_FILE_BYTES",
    "MAX_MEMORY_INPUTS",
    "MAX_ZERO_TAIL_BYTES",
    "N_CHANNELS",
    "N_VALUES",
    "READABLE_SCHEMAS",
    "SCHEMA_VERSION",
    "SOURCES",
    "Demonstration",
    "DemonstrationWriter",
    "load_demonstration",
    "save_demonstration",
]
