"""study.json versions: the current schema and one migration function per step from older ones.

A study writes study.json (this schema), study.md, study.png and study.csv (views of study.json,
redrawn from it), and for each job the benchmark's results.json (its own schema,
:mod:`lfd_track.benchmark.schema`) and report.md. Every reader of a study.json goes through
:func:`read_study_results` or :func:`migrate_study`.

Schema history:

* **1** — each condition's ``config`` left out the settings a results.json of schema 1 left out.
* **2** — each condition's ``config`` holds every setting (as results.json schema 2).
* **3** — each condition's ``config`` holds the ``direct`` and ``mu_plus_one`` tables (as
  results.json schema 3).
* **4** — each condition's ``config.memory`` names every memory setting added since (as
  results.json schema 4: the ``fresh_felt`` map's ``geometry``, ``"paper"`` in older files).
* **5** — the same for the ``fresh_felt`` map's ``motion`` (as results.json schema 5,
  ``"nominal"`` in older files).
* **6** — the same for the ``fresh_felt`` map's ``branch_side`` (as results.json schema 6,
  ``false`` in older files).
* **7** — the same for the branch side's ``branch_window`` (as results.json schema 7,
  ``"forward"`` in older files).
* **8** — the same for the branch side's ``branch_turn`` (as results.json schema 8, ``false`` in
  older files).
* **9** — the same for ``branch_turn_from`` (as results.json schema 9, ``"set"`` in older files).
* **10** — the same for ``colour_balance`` (as results.json schema 10, ``"none"`` in older
  files).
* **11** — the same for ``registration`` (as results.json schema 11, ``"full"`` in older files).
* **12** — the same for ``visited_from`` (as results.json schema 12, ``"path"`` in older files).
* **13** — the same for ``fresh_sight_m`` (as results.json schema 13, ``0.0`` in older files).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from ..benchmark.schema import (
    MEMORY_SETTING_SINCE,
    config_v1_to_v2,
    config_v2_to_v3,
    config_v3_to_v4,
)
from ..utils.migrate import Step, VersionedJson

STUDY_SCHEMA = 13
"""Schema of the study.json this version writes (``len(STUDY_STEPS) + 1``)."""
MAX_STUDY_BYTES = 1 << 28
"""Largest study.json read."""


def study_v1_to_v2(data: dict[str, Any]) -> dict[str, Any]:
    """Schema 1 -> 2: every setting in each condition's ``config``."""
    return _each_config(data, config_v1_to_v2, 2)


def study_v2_to_v3(data: dict[str, Any]) -> dict[str, Any]:
    """Schema 2 -> 3: the ``direct`` and ``mu_plus_one`` tables in each condition's ``config``."""
    return _each_config(data, config_v2_to_v3, 3)


def _each_config(data: dict[str, Any], step: Callable[[Any], Any], schema: int) -> dict[str, Any]:
    """``data`` with each condition's ``config`` passed through the results.json config ``step``
    (the conditions that are not tables, or hold no ``config``, left for the reader's checks),
    as schema ``schema``."""
    conditions = data.get("conditions")
    for condition in conditions if isinstance(conditions, list) else []:
        if isinstance(condition, dict) and "config" in condition:
            condition["config"] = step(condition["config"])
    data["schema"] = schema
    return data


def study_v3_to_v4(data: dict[str, Any]) -> dict[str, Any]:
    """Schema 3 -> 4: the memory settings added since in each condition's ``config``."""
    return _each_config(data, config_v3_to_v4, 4)


def _memory_step(schema: int) -> Step:
    """The step ``schema - 1`` -> ``schema`` (from 5 on): the memory settings added since in each
    condition's ``config`` (as results.json's step to that schema,
    :data:`~lfd_track.benchmark.schema.MEMORY_SETTING_SINCE`)."""

    def step(data: dict[str, Any]) -> dict[str, Any]:
        return _each_config(data, config_v3_to_v4, schema)

    step.__name__ = step.__qualname__ = f"study_v{schema - 1}_to_v{schema}"
    step.__doc__ = (
        f"Schema {schema - 1} -> {schema}: the memory settings added since"
        f" (``{MEMORY_SETTING_SINCE[schema]}``) in each condition's ``config``."
    )
    return step


STUDY_STEPS: tuple[Step, ...] = (
    study_v1_to_v2,
    study_v2_to_v3,
    study_v3_to_v4,
    *(_memory_step(schema) for schema in sorted(MEMORY_SETTING_SINCE)),
)
"""Step k turns a schema-k study.json dict into schema k + 1."""
STUDY_FORMAT = VersionedJson("study", STUDY_STEPS, MAX_STUDY_BYTES)
"""study.json: its steps and largest size; :func:`read_study_results` (a file) and
:func:`migrate_study` (a dict already parsed) are its ``read`` and ``migrate``."""
migrate_study = STUDY_FORMAT.migrate
read_study_results = STUDY_FORMAT.read
