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
"""

from __future__ import annotations

from typing import Any

from ..benchmark.schema import config_v1_to_v2, config_v2_to_v3
from ..utils.migrate import Step, VersionedJson

STUDY_SCHEMA = 3
"""Schema of the study.json this version writes (``len(STUDY_STEPS) + 1``)."""
MAX_STUDY_BYTES = 1 << 28
"""Largest study.json read."""


def study_v1_to_v2(data: dict[str, Any]) -> dict[str, Any]:
    """Schema 1 -> 2: every setting in each condition's ``config``."""
    conditions = data.get("conditions")
    for condition in conditions if isinstance(conditions, list) else []:
        if isinstance(condition, dict) and "config" in condition:
            condition["config"] = config_v1_to_v2(condition["config"])
    data["schema"] = 2
    return data


def study_v2_to_v3(data: dict[str, Any]) -> dict[str, Any]:
    """Schema 2 -> 3: the ``direct`` and ``mu_plus_one`` tables in each condition's ``config``."""
    conditions = data.get("conditions")
    for condition in conditions if isinstance(conditions, list) else []:
        if isinstance(condition, dict) and "config" in condition:
            condition["config"] = config_v2_to_v3(condition["config"])
    data["schema"] = 3
    return data


STUDY_STEPS: tuple[Step, ...] = (study_v1_to_v2, study_v2_to_v3)
"""Step k turns a schema-k study.json dict into schema k + 1."""
STUDY_FORMAT = VersionedJson("study", STUDY_STEPS, MAX_STUDY_BYTES)
"""study.json: its steps and largest size, read through :func:`read_study_results`."""

migrate_study = STUDY_FORMAT.migrate
"""``migrate_study(data, source)``: a study.json dict (parsed from ``source``) in the current
schema (:meth:`~lfd_track.utils.migrate.VersionedJson.migrate`); ``data`` is kept."""
read_study_results = STUDY_FORMAT.read
"""``read_study_results(path, max_bytes=None)``: the study.json at ``path``, parsed and migrated
to the current schema (:meth:`~lfd_track.utils.migrate.VersionedJson.read`)."""
