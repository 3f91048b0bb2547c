"""Every committed study file loads, and its committed results folder holds every one of its jobs,
finished with the settings the file asks for (so re-running its command resumes, runs no job and
only rewrites the summary)."""

from __future__ import annotations

from pathlib import Path

import pytest

from lfd_track.study.run import load_finished
from lfd_track.study.spec import load_study

REPO = Path(__file__).resolve().parents[2]
EXPERIMENTS = REPO / "benchmarks" / "experiments"
# A study file X.toml keeps its results in results/X/ beside it; tracks/ beside a study holds
# track files it names, not studies; planned/ holds study files written but not yet run.
_TOML = sorted(p for p in EXPERIMENTS.rglob("*.toml") if p.parent.name != "tracks")
STUDIES = [str(p.relative_to(REPO)) for p in _TOML if p.parent.name != "planned"]
PLANNED = [str(p.relative_to(REPO)) for p in _TOML if p.parent.name == "planned"]


def test_every_committed_study_is_found():
    assert len(STUDIES) == 48


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
