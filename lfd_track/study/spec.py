"""Study files: conditions x seeds of the paper protocol, read from TOML and validated.

A study file looks like::

    [study]
    schema = 3                       # the file's schema (absent: 1, see below)
    name = "beyond_the_paper"        # optional, default: the file name
    description = "..."              # optional
    seeds = [0, 1, 2]                # benchmark seeds, the same for every condition
    repetitions = 10                 # repetitions per (condition, seed) job

    [defaults]                       # optional: settings every condition starts from
    trials_per_direction = 3
    test_tracks = ["loop_a"]

    [[conditions]]
    name = "paper"                   # unique; letters, digits, '.', '_', '+', '-'
    method = "paper"
    preset = "paper"                 # a shipped preset name, or a path relative to this file
    [conditions.ga]                  # GA settings (see GAConfig); likewise [conditions.human]
    generations = 200

A condition's keys (after ``[defaults]`` are merged in, table by table) are ``name``,
``description`` and any field of :class:`~lfd_track.benchmark.config.BenchmarkConfig` except
``seed``, ``repetitions`` (which the study sets) and ``method_settings``: nested settings such as
``ga`` or ``human`` are tables of their config's fields. A method's settings are the table its
registry entry names (:mod:`lfd_track.methods`: ``[conditions.online]``,
``[conditions.dagger]`` …), read by the settings class the entry gives, for every registered
method, the built-in ones and any registered from outside the package. Every (condition, seed) pair is one job: one run of the
paper protocol, ``BenchmarkConfig(seed=seed, repetitions=repetitions, ...)``.

A condition's ``[memory]`` table names its ``kind`` and that kind's settings
(:mod:`lfd_track.policy.memory_config`; settings not named take the shipped defaults: for
``fresh_felt`` the goal's chosen map). A file without ``[study] schema`` is schema 1, written when
every ``fresh_felt`` option was off unless named: each condition's memory table (after
``[defaults]`` is merged in) is read through
:func:`~lfd_track.policy.memory_config.memory_table_from_v1`, so the file means what it meant
(:data:`STUDY_MIGRATIONS`, one function per schema step). A file of schema 2 was written when
every ``fresh_felt`` map had the paper's geometry: each condition's ``fresh_felt`` memory table
that does not name ``geometry`` reads as ``geometry = "paper"`` (the paper's camera, 0.10 m,
22.9°; :mod:`lfd_track.policy.map_geometry`), where a schema-3 file's means the default,
``"world"`` (the camera and motion of the preset the policy is taught in). The human's settings
did not change meaning between the schemas.

Anything wrong in the file (unknown key, wrong type, unknown method, preset or track, duplicate
name, a number out of bounds) raises :class:`~lfd_track.errors.FileFormatError`: one line naming
the file and the problem, before any job runs or any folder is made.

Bounds, generous for real studies but keeping each job's memory and run time finite: ``seeds``
are integers 0 to 2**32 - 1 (numpy's seed range, :data:`MAX_SEED`), ``repetitions`` 1 to
:data:`MAX_REPETITIONS` (10,000). A condition's settings are checked by their configs when the
file is loaded, and those configs bound their integer settings (``BenchmarkConfig``,
``GAConfig`` and the learners' configs state their limits). The integer settings whose configs
set no upper bound are bounded here, by :data:`SETTING_LIMITS`: ``human.max_commands`` 1 to
1,000,000, ``human.library_only_commands`` ≤ 100,000, ``human.legs`` ≤ 1,000,
``intervention.stall_commands`` ≤ 10,000 (the memory settings' bounds are their classes'); any
other integer
setting without a bound of its own by :data:`OTHER_SETTING_LIMIT` (10**9), and all of them are
at least 0. Nested tables (``[conditions.online.intervention]``) are checked key by key too.

Every test track must be a closed loop with at least one corner (laps are scored corner by
corner); with ``check_names`` this is checked when the file is loaded.
"""

from __future__ import annotations

import dataclasses
import os
import re
import typing
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..benchmark.runner import BenchmarkConfig, check_tracks, settings_arguments
from ..core.config import dataclass_from_table, read_toml
from ..errors import FileFormatError, LfdTrackError
from ..learning.extra_cases import load_cases
from ..learning.result import shown_int
from ..methods import method_names, method_of_table
from ..policy.memory_config import (
    MEMORY_CONFIGS,
    memory_config,
    memory_table_from_v1,
    setting_specs,
)

_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._+-]{0,63}$")
_STUDY_KEYS = {"schema", "name", "description", "seeds", "repetitions"}
_TOP_KEYS = {"study", "defaults", "conditions"}
_SET_BY_STUDY = {"seed", "repetitions"}
# Benchmark settings a study may name before this build's BenchmarkConfig has them.
MAX_SEED = 2**32 - 1
"""Largest benchmark seed (numpy's legacy seed range; folders are named ``seed<k>``)."""
MAX_REPETITIONS = 10_000
"""Most repetitions per job (each one a demonstration, a learning run and its trials)."""
SETTING_LIMITS: dict[str, int] = {
    "human.library_only_commands": 100_000,
    "human.legs": 1_000,
    "human.max_commands": 1_000_000,
    "online.intervention.stall_commands": 10_000,
    "hg_dagger.intervention.stall_commands": 10_000,
}
"""Largest value of the integer settings whose configs set no bound (dotted: table.key); the
others are bounded by their configs, which are built (and so checked) first."""
OTHER_SETTING_LIMIT = 10**9
"""Largest value of an integer setting missing from :data:`SETTING_LIMITS`."""
SETTING_MINIMUMS: dict[str, int] = {"human.max_commands": 1}
"""Smallest value of an integer setting where its config does not check it (else 0)."""
STUDY_SCHEMA_VERSION = 3
"""Schema of a study file that names none is 1; this build reads 1 to 3."""
SETTINGS_SINCE_SCHEMA3: tuple[str, ...] = ("geometry",)
"""Memory settings a schema-2 file could not name: it is read with each one's ``before`` (what
the memory did before the setting existed)."""


def _condition_from_schema1(table: dict[str, Any]) -> dict[str, Any]:
    """Schema 1 -> 2 of one condition's table (``[defaults]`` merged in): its memory table, whose
    ``fresh_felt`` options not named were off, as the full table meaning the same map."""
    if not isinstance(table.get("memory"), dict):
        return table
    return {**table, "memory": memory_table_from_v1(table["memory"])}


def _condition_from_schema2(table: dict[str, Any]) -> dict[str, Any]:
    """Schema 2 -> 3 of one condition's table: its memory table gains each setting of
    :data:`SETTINGS_SINCE_SCHEMA3` it does not name, at the value that does what the memory did
    then (``geometry = "paper"``: the paper's camera and motion)."""
    memory = table.get("memory")
    if not isinstance(memory, dict):
        return table
    kind = memory.get("kind", "none")
    cls = MEMORY_CONFIGS.get(kind) if isinstance(kind, str) else None
    if cls is None:  # an unknown kind is named by the reader's checks
        return table
    before = {s.name: s.before for s in setting_specs(cls) if s.name in SETTINGS_SINCE_SCHEMA3}
    return {**table, "memory": {**before, **memory}}


STUDY_MIGRATIONS: dict[int, typing.Callable[[dict[str, Any]], dict[str, Any]]] = {
    1: _condition_from_schema1,
    2: _condition_from_schema2,
}
"""One migration per schema step: ``STUDY_MIGRATIONS[k]`` turns a condition's table of a schema-k
file into one of schema k + 1 meaning the same condition."""


@dataclass(frozen=True)
class Condition:
    """One row of the study's table: a named benchmark setting run for every seed."""

    name: str
    """Unique name, also the folder of its jobs' results."""
    description: str
    """Free text (may be empty)."""
    config: BenchmarkConfig
    """The benchmark settings; ``seed`` and ``repetitions`` are replaced per job."""
    method: str = "paper"
    """Learning method (as the study file names it)."""
    test_tracks: tuple[str, ...] = ()
    """Extra tracks the controllers are scored on, beyond the paper's two."""


@dataclass(frozen=True)
class Job:
    """One (condition, seed) run of the paper protocol."""

    condition: str
    """Name of the condition."""
    seed: int
    """Benchmark seed (matched across conditions)."""
    config: BenchmarkConfig
    """Complete benchmark settings of this job."""

    @property
    def key(self) -> str:
        """Folder of the job's results relative to the study's output folder."""
        return f"{self.condition}/seed{self.seed}"


@dataclass(frozen=True)
class Study:
    """A validated study file."""

    name: str
    description: str
    source: str
    """Path of the study file."""
    seeds: tuple[int, ...]
    repetitions: int
    conditions: tuple[Condition, ...]

    def jobs(self) -> list[Job]:
        """Every (condition, seed) job, seed by seed (so a study stopped early still compares every
        condition on the same seeds), conditions in file order."""
        return [
            Job(
                condition=c.name,
                seed=seed,
                config=dataclasses.replace(c.config, seed=seed, repetitions=self.repetitions),
            )
            for seed in self.seeds
            for c in self.conditions
        ]


# ------------------------------------------------------------------------------------- loading
def load_study(path: str | Path, *, check_names: bool = True) -> Study:
    """Read and validate a study file.

    With ``check_names`` (the default) every method, preset and track named must exist in this
    build; ``check_names=False`` checks only the file's structure and types.
    """
    path = Path(path)
    data = read_toml(path)
    unknown = sorted(set(data) - _TOP_KEYS)
    if unknown:
        raise FileFormatError(path, f"unknown table or key '{unknown[0]}'")
    study = data.get("study")
    if not isinstance(study, dict):
        raise FileFormatError(path, "missing the [study] table (seeds and repetitions)")
    unknown = sorted(set(study) - _STUDY_KEYS)
    if unknown:
        raise FileFormatError(path, f"unknown key 'study.{unknown[0]}'")
    schema = study.get("schema", 1)
    if isinstance(schema, bool) or schema not in range(1, STUDY_SCHEMA_VERSION + 1):
        raise FileFormatError(
            path,
            f"'study.schema' must be one of 1..{STUDY_SCHEMA_VERSION} (this build's), got"
            f" {_show(schema)}",
        )
    name = study.get("name", path.stem)
    description = study.get("description", "")
    if not isinstance(name, str) or not _NAME.match(name):
        raise FileFormatError(path, f"'study.name' must be a short name, got {name!r}")
    if not isinstance(description, str):
        raise FileFormatError(path, "'study.description' must be a string")
    seeds = study.get("seeds")
    if (
        not isinstance(seeds, list)
        or not seeds
        or any(isinstance(s, bool) or not isinstance(s, int) or s < 0 for s in seeds)
    ):
        raise FileFormatError(
            path,
            f"'study.seeds' must be a non-empty list of integers >= 0, got {_show(seeds)}",
        )
    too_large = [s for s in seeds if s > MAX_SEED]
    if too_large:
        raise FileFormatError(
            path,
            f"'study.seeds' must be integers from 0 to {MAX_SEED}, got {_show(too_large[0])}",
        )
    if len(set(seeds)) != len(seeds):
        raise FileFormatError(path, f"'study.seeds' lists a seed twice: {_show(seeds)}")
    repetitions = study.get("repetitions")
    if isinstance(repetitions, bool) or not isinstance(repetitions, int) or repetitions < 1:
        raise FileFormatError(
            path, f"'study.repetitions' must be an integer >= 1, got {_show(repetitions)}"
        )
    if repetitions > MAX_REPETITIONS:
        raise FileFormatError(
            path,
            f"'study.repetitions' must be at most {MAX_REPETITIONS}, got {_show(repetitions)}",
        )

    defaults = data.get("defaults", {})
    if not isinstance(defaults, dict):
        raise FileFormatError(path, "[defaults] must be a table")
    tables = data.get("conditions")
    if not isinstance(tables, list) or not tables:
        raise FileFormatError(path, "no [[conditions]]: a study needs at least one condition")
    conditions: list[Condition] = []
    for index, table in enumerate(tables):
        if not isinstance(table, dict):
            raise FileFormatError(path, f"condition {index + 1} must be a table")
        merged = _merge(defaults, table)
        try:
            for step in range(schema, STUDY_SCHEMA_VERSION):
                merged = STUDY_MIGRATIONS[step](merged)
        except ValueError as exc:
            raise FileFormatError(path, f"condition {index + 1}: {exc}") from None
        condition = _condition(merged, index, path, check_names)
        if any(c.name == condition.name for c in conditions):
            raise FileFormatError(path, f"two conditions are named '{condition.name}'")
        conditions.append(condition)
    return Study(
        name=name,
        description=description,
        source=str(path),
        seeds=tuple(seeds),
        repetitions=repetitions,
        conditions=tuple(conditions),
    )


def _merge(defaults: dict[str, Any], table: dict[str, Any]) -> dict[str, Any]:
    """``defaults`` overlaid by ``table``; nested tables are merged key by key."""
    out = dict(defaults)
    for key, value in table.items():
        if isinstance(value, dict) and isinstance(out.get(key), dict):
            out[key] = _merge(out[key], value)
        else:
            out[key] = value
    return out


def _condition(table: dict[str, Any], index: int, path: Path, check_names: bool) -> Condition:
    name = table.get("name")
    if not isinstance(name, str) or not _NAME.match(name):
        raise FileFormatError(
            path,
            f"condition {index + 1} needs a 'name' of letters, digits, '.', '_', '+', '-' "
            f"(got {name!r})",
        )
    where = f"condition '{name}'"
    description = table.get("description", "")
    if not isinstance(description, str):
        raise FileFormatError(path, f"{where}: 'description' must be a string")
    fields = {f.name: f for f in dataclasses.fields(BenchmarkConfig)}
    hints = typing.get_type_hints(BenchmarkConfig)
    settings: dict[str, Any] = {}
    method_tables: dict[str, Any] = {}
    for key, value in table.items():
        if key in ("name", "description"):
            continue
        if key in _SET_BY_STUDY:
            raise FileFormatError(
                path, f"{where}: '{key}' is set by the [study] table, not per condition"
            )
        method = method_of_table(key)
        if method is not None and method.settings is not None:  # read by the registry's class
            method_tables[key] = _settings_from_table(method.settings, value, f"{name}.{key}", path)
            continue
        if key not in fields or key == "method_settings":
            raise FileFormatError(path, f"{where}: unknown key '{key}'")
        kind = hints[key]
        if key == "memory":  # one class per memory kind: the kind picks it
            try:
                settings[key] = memory_config(value)
            except ValueError as exc:
                raise FileFormatError(path, f"[{name}.memory] {exc}") from None
        elif dataclasses.is_dataclass(kind):
            settings[key] = _settings_from_table(kind, value, f"{name}.{key}", path)
        else:
            settings[key] = value
    settings.update(settings_arguments(method_tables))
    for key in ("preset", "test_tracks", "demo_track"):
        if key in settings:
            settings[key] = _relative_to(settings[key], path)
    cases = settings.get("extra_cases")
    if isinstance(cases, str) and cases and not Path(cases).is_absolute():
        # saved cases are always a path, relative to the study file's folder
        settings["extra_cases"] = os.path.normpath(path.parent / cases)
    config = dataclass_from_table(BenchmarkConfig, settings, name, path)
    _check_limits(config, where, path)
    method = getattr(config, "method", table.get("method", "paper"))
    tracks = getattr(config, "test_tracks", table.get("test_tracks", ()))
    if not isinstance(method, str):
        raise FileFormatError(path, f"{where}: 'method' must be a string, got {method!r}")
    if not isinstance(tracks, list | tuple) or not all(isinstance(t, str) for t in tracks):
        raise FileFormatError(path, f"{where}: 'test_tracks' must be a list of track names")
    if check_names:
        check_condition_names(config, where, path)
    return Condition(
        name=name,
        description=description,
        config=config,
        method=method,
        test_tracks=tuple(tracks),
    )


def _settings_from_table(kind: Any, table: Any, where: str, path: Path) -> Any:
    """``dataclass_from_table``, with nested settings tables (``online.intervention``) built
    as their own config too, so their keys and types are checked here, not when a job runs."""
    if isinstance(table, dict):
        hints = typing.get_type_hints(kind)
        table = {
            k: _settings_from_table(hints[k], v, f"{where}.{k}", path)
            if k in hints and dataclasses.is_dataclass(hints[k])
            else v
            for k, v in table.items()
        }
    return dataclass_from_table(kind, table, where, path)


def _check_limits(config: Any, where: str, path: Path, prefix: str = "") -> None:
    """Raise ``FileFormatError`` if an integer setting of ``config`` (nested settings included)
    exceeds its bound in :data:`SETTING_LIMITS`, or is below its :data:`SETTING_MINIMUMS` (0
    unless listed); the study's own keys are checked apart."""
    for field in dataclasses.fields(config):
        key = f"{prefix}{field.name}"
        value = getattr(config, field.name)
        if dataclasses.is_dataclass(value) and not isinstance(value, type):
            _check_limits(value, where, path, f"{key}.")
        elif field.name == "method_settings" and not prefix:  # other methods' settings tables
            for table, settings in value.items():
                _check_limits(settings, where, path, f"{table}.")
        elif isinstance(value, int) and not isinstance(value, bool) and key not in _SET_BY_STUDY:
            limit = SETTING_LIMITS.get(key, OTHER_SETTING_LIMIT)
            if value > limit:
                raise FileFormatError(
                    path, f"{where}: '{key}' must be at most {limit}, got {_show(value)}"
                )
            least = SETTING_MINIMUMS.get(key, 0)
            if value < least:
                raise FileFormatError(
                    path, f"{where}: '{key}' must be at least {least}, got {_show(value)}"
                )


def _show(value: Any) -> str:
    """``repr(value)``, with huge integers and long lists shortened: a huge number in a file
    gives a short message."""
    if isinstance(value, list):
        shown = [_show(v) for v in value[:5]]
        return "[" + ", ".join(shown) + (", ...]" if len(value) > 5 else "]")
    if isinstance(value, int) and not isinstance(value, bool):
        return shown_int(value)  # str() would even refuse one of over 4300 digits
    return repr(value)


def _relative_to(value: Any, study_path: Path) -> Any:
    """Preset or track paths (not bare names) are relative to the study file's folder (as a
    normal path: ``planned/../presets/a.toml`` is ``presets/a.toml``)."""
    if isinstance(value, list):
        return [_relative_to(v, study_path) for v in value]
    if isinstance(value, str) and ("/" in value or value.endswith(".toml")):
        candidate = Path(value)
        if not candidate.is_absolute():
            return os.path.normpath(study_path.parent / candidate)
    return value


# ------------------------------------------------------------------------------- name checks
def available_methods() -> tuple[str, ...]:
    """Learning methods this build's benchmark can run: the registered ones
    (:func:`lfd_track.methods.method_names`)."""
    return method_names()


def check_condition_names(config: BenchmarkConfig, where: str, path: Path | str) -> None:
    """Raise ``FileFormatError`` unless the method, preset, tracks and saved cases named exist
    here."""
    from ..envs.presets import load_preset
    from ..world.track import load_track

    method = getattr(config, "method", "paper")
    methods = available_methods()
    if method not in methods:
        raise FileFormatError(
            path, f"{where}: unknown method '{method}' (this build has: {', '.join(methods)})"
        )
    try:
        load_preset(config.preset)
    except LfdTrackError as exc:
        raise FileFormatError(path, f"{where}: preset: {_one_line(exc)}") from None
    for track in getattr(config, "test_tracks", ()):
        try:
            load_track(track)
        except LfdTrackError as exc:
            raise FileFormatError(path, f"{where}: test track: {_one_line(exc)}") from None
    if config.extra_cases:
        try:
            load_cases(config.extra_cases)
        except LfdTrackError as exc:
            raise FileFormatError(path, f"{where}: extra_cases: {_one_line(exc)}") from None
    # What the benchmark checks before it runs (test tracks are loops with corners, every track
    # fits the preset's ground texture), here at load time, before any job runs.
    try:
        check_tracks(config)
    except (LfdTrackError, ValueError) as exc:
        raise FileFormatError(path, f"{where}: {_one_line(exc)}") from None


def _one_line(exc: BaseException) -> str:
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__
