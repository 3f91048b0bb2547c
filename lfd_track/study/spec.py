"""Study files: conditions x seeds of the paper protocol, read from TOML and validated.

A study file looks like::

    [study]
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
``description`` and any field of :class:`~lfd_track.benchmark.runner.BenchmarkConfig` except
``seed`` and ``repetitions`` (which the study sets): nested settings such as ``ga`` or ``human``
are tables of their config's fields. Every (condition, seed) pair is one job: one run of the
paper protocol, ``BenchmarkConfig(seed=seed, repetitions=repetitions, ...)``.

Anything wrong in the file (unknown key, wrong type, unknown method, preset or track, duplicate
name) raises :class:`~lfd_track.errors.FileFormatError`: one line naming the file and the problem.
"""

from __future__ import annotations

import dataclasses
import re
import typing
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..benchmark.runner import BenchmarkConfig
from ..config import dataclass_from_table, read_toml
from ..errors import FileFormatError, LfdTrackError

_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._+-]{0,63}$")
_STUDY_KEYS = {"name", "description", "seeds", "repetitions"}
_TOP_KEYS = {"study", "defaults", "conditions"}
_SET_BY_STUDY = {"seed", "repetitions"}
# Benchmark settings a study may name before this build's BenchmarkConfig has them.


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
            path, f"'study.seeds' must be a non-empty list of integers >= 0, got {seeds!r}"
        )
    if len(set(seeds)) != len(seeds):
        raise FileFormatError(path, f"'study.seeds' lists a seed twice: {seeds}")
    repetitions = study.get("repetitions")
    if isinstance(repetitions, bool) or not isinstance(repetitions, int) or repetitions < 1:
        raise FileFormatError(
            path, f"'study.repetitions' must be an integer >= 1, got {repetitions!r}"
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
        condition = _condition(_merge(defaults, table), index, path, check_names)
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
    for key, value in table.items():
        if key in ("name", "description"):
            continue
        if key in _SET_BY_STUDY:
            raise FileFormatError(
                path, f"{where}: '{key}' is set by the [study] table, not per condition"
            )
        if key not in fields:
            raise FileFormatError(path, f"{where}: unknown key '{key}'")
        kind = hints[key]
        if dataclasses.is_dataclass(kind):
            settings[key] = dataclass_from_table(kind, value, f"{name}.{key}", path)
        else:
            settings[key] = value
    for key in ("preset", "test_tracks"):
        if key in settings:
            settings[key] = _relative_to(settings[key], path)
    config = dataclass_from_table(BenchmarkConfig, settings, name, path)
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


def _relative_to(value: Any, study_path: Path) -> Any:
    """Preset or track paths (not bare names) are relative to the study file's folder."""
    if isinstance(value, list):
        return [_relative_to(v, study_path) for v in value]
    if isinstance(value, str) and ("/" in value or value.endswith(".toml")):
        candidate = Path(value)
        if not candidate.is_absolute():
            return str(study_path.parent / candidate)
    return value


# ------------------------------------------------------------------------------- name checks
def available_methods() -> tuple[str, ...] | None:
    """Learning methods this build's benchmark can run, or None if it only knows them by
    validating a ``BenchmarkConfig`` (then a bad method fails when the condition is built)."""
    from ..benchmark import runner

    for attribute in ("METHODS", "METHOD_NAMES"):
        names = getattr(runner, attribute, None)
        if names:
            return tuple(str(n) for n in names)
    return None


def check_condition_names(config: BenchmarkConfig, where: str, path: Path | str) -> None:
    """Raise ``FileFormatError`` unless the method, preset and tracks named exist here."""
    from ..presets import load_preset
    from ..world.track import load_track

    method = getattr(config, "method", "paper")
    methods = available_methods()
    if methods is not None and method not in methods:
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


def _one_line(exc: BaseException) -> str:
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__
