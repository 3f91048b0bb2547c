"""Every committed study file loads, and its committed results folder holds every one of its jobs,
finished with the settings the file asks for (so re-running its command resumes, runs no job and
only rewrites the summary)."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import pytest

from lfd_track.policy.memory_config import REMOVED_SETTINGS, setting_specs
from lfd_track.study.run import load_finished
from lfd_track.study.spec import load_study

REPO = Path(__file__).resolve().parents[2]
EXPERIMENTS = REPO / "benchmarks" / "experiments"
# A study file X.toml keeps its results in results/X/ beside it; tracks/ and presets/ beside a
# study hold track and preset files it names, not studies; trials/ holds study files that only
# define the trials a script drives (e.g. rules.py's --study), never run as studies; planned/
# holds study files written but not yet run.
_TOML = sorted(
    p for p in EXPERIMENTS.rglob("*.toml") if p.parent.name not in ("tracks", "presets", "trials")
)
STUDIES = [str(p.relative_to(REPO)) for p in _TOML if p.parent.name != "planned"]
PLANNED = [str(p.relative_to(REPO)) for p in _TOML if p.parent.name == "planned"]


def test_every_committed_study_is_found():
    assert len(STUDIES) == 165


@pytest.mark.parametrize("study_file", PLANNED)
def test_a_planned_study_loads_and_has_no_results_yet(study_file, monkeypatch):
    monkeypatch.chdir(REPO)
    path = Path(study_file)
    load_study(path)
    assert not (path.parent.parent / "results" / path.stem / "study.json").exists()


@pytest.mark.parametrize("study_file", STUDIES)
def test_committed_study_loads_and_its_results_are_complete(study_file, monkeypatch):
    # Run from the repository root, as the commands in the experiments' READMEs are: the paths a
    # study names are stored relative to where the study was run.
    monkeypatch.chdir(REPO)
    path = Path(study_file)
    study = load_study(path)
    out = path.parent / "results" / path.stem
    assert (out / "study.json").is_file() and (out / "study.md").is_file()
    jobs = load_finished(study, out)
    assert len(jobs) == len(study.conditions) * len(study.seeds)


# What the code before study schema 2 made of each condition's memory and human settings (every
# field; tests/data/committed_studies_v1_settings.json, written by that code from these files).
_V1 = json.loads((REPO / "tests" / "data" / "committed_studies_v1_settings.json").read_text())


def test_every_committed_study_keeps_its_memory_and_human_settings(monkeypatch):
    """Schema-1 files (no ``[study] schema``) are migrated on reading, and files rewritten since
    against the new defaults (``chosen.toml``) say the same: every condition's map is the one it
    was, with the settings removed since at the only value they keep."""
    monkeypatch.chdir(REPO)
    seen = set()
    for study_file in STUDIES:
        study = load_study(study_file, check_names=False)
        for condition in study.conditions:
            key = f"{study.name}/{condition.name}"
            if key not in _V1["conditions"]:
                continue  # a study written after schema 2 (nothing older to keep)
            memory_index, human_index = _V1["conditions"][key]
            old = _V1["memory"][memory_index]
            memory = condition.config.memory
            fields = [f.name for f in dataclasses.fields(memory)]
            # a setting added since means what the map did before it (geometry: the paper's)
            before = {s.name: s.before for s in setting_specs(type(memory))}
            meant = {f: old.get(f, before[f]) for f in fields}
            assert memory.to_dict() == {"kind": old["kind"], **meant}, key
            removed = REMOVED_SETTINGS.get(memory.kind, {})
            assert {k: old[k] for k in removed} == removed, key
            human = dataclasses.asdict(condition.config.human)
            # a human setting added since means what every human did before it: no nudges
            assert human.pop("nudge_prob") == 0.0, key
            assert human.pop("nudge_side") == "random", key
            assert human == _V1["human"][human_index], key
            seen.add(key)
    assert seen == set(_V1["conditions"])  # every condition of every committed study
