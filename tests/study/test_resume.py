"""Resuming a study: stored results.json files are validated before any job runs.

A damaged results.json (hand-edited, truncated, written by something else) is refused with one
line naming the file; it is never rerun over or deleted, and no other job runs meanwhile.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest
from study_helpers import job_results, outcome, write_study

import lfd_track.study.run as run_module
from lfd_track.cli import main
from lfd_track.errors import FileFormatError
from lfd_track.study.jobs import RESULTS_FILE, finished_results
from lfd_track.study.run import load_finished, run_study
from lfd_track.study.spec import load_study
from lfd_track.study.summary import build_study_results


@pytest.fixture
def stored(tmp_path, monkeypatch):
    """(study, out, first job, path of its results.json); running a job fails the test."""

    def no_job(job):
        raise AssertionError(f"job {job.key} ran although a stored result is damaged")

    monkeypatch.setattr(run_module, "run_job", no_job)
    study = load_study(write_study(tmp_path))
    job = study.jobs()[0]
    path = tmp_path / "out" / job.key / RESULTS_FILE
    path.parent.mkdir(parents=True)
    return study, tmp_path / "out", job, path


def _with(results: dict, key: str, value) -> dict:
    out = dict(results)
    if value is _DELETE:
        del out[key]
    else:
        out[key] = value
    return out


def _outcome_with(key: str, value) -> dict:
    o = outcome("testing", "ccw")
    if value is _DELETE:
        del o[key]
    else:
        o[key] = value
    return o


_DELETE = object()
FULL = [  # the four trials job_results() holds, in its order
    outcome("training", "direction_1", ["1", "2"]),
    outcome("training", "direction_2", ["1"]),
    outcome("testing", "ccw"),
    outcome("testing", "cw", ["4"]),
]

DAMAGED = [
    ("outcomes", _DELETE, "'outcomes'"),
    ("outcomes", "abc", "'outcomes' must be a list"),
    ("outcomes", [1, 2], "outcomes[0] must be an object"),
    ("outcomes", [{}], "outcomes[0]: missing 'track'"),
    ("outcomes", [_outcome_with("success", _DELETE)], "outcomes[0]: missing 'success'"),
    ("outcomes", [_outcome_with("success", "yes")], "outcomes[0]: 'success'"),
    ("outcomes", [_outcome_with("track", 5)], "outcomes[0]: 'track'"),
    ("outcomes", [_outcome_with("corner_order", "abc")], "outcomes[0]: 'corner_order'"),
    ("outcomes", [_outcome_with("corner_order", [])], "corner_order"),
    ("outcomes", [_outcome_with("repetition", "x")], "outcomes[0]: 'repetition'"),
    ("outcomes", [_outcome_with("repetition", 5)], "outcomes[0]: 'repetition'"),
    ("outcomes", [_outcome_with("failure", ["x"])], "outcomes[0]: 'failure'"),
    ("outcomes", [_outcome_with("failure", "reversed")], "succeeds exactly when"),
    ("outcomes", [_outcome_with("direction", "up")], "direction must be one of"),
    # The trials must be exactly the job's: every direction, repetition and trial once.
    ("outcomes", FULL[:3], "holds 0 of the 1 trial(s) of testing/cw (1 repetition(s) x 1"),
    ("outcomes", FULL[1:], "holds 0 of the 1 trial(s) of training/direction_1"),
    ("outcomes", [], "holds 0 of the 1 trial(s) of training/direction_1"),
    ("outcomes", [*FULL, FULL[2]], "outcomes[4]: testing/ccw repetition 0 trial 0 is listed twice"),
    ("outcomes", [*FULL[:3], {**FULL[3], "trial": 1}], "outcomes[3]: 'trial' must be below the"),
    ("outcomes", [*FULL, outcome("kite", "ccw", ["1"])], "outcomes[4]: the job drives no track"),
    ("timing_s", "x", "'timing_s' must be an object"),
    ("timing_s", {"wall": "x"}, "'timing_s.wall' must be a finite number"),
    ("training_accuracy", "abc", "'training_accuracy' must be a list"),
    ("training_accuracy", [0.5, "x"], "'training_accuracy[1]'"),
    ("demonstrations", _DELETE, "'demonstrations'"),
    ("demonstrations", [{"cases": "x"}], "'demonstrations[0].cases'"),
    ("human_effort", "x", "'human_effort' must be an object"),
    ("human_effort", {"total": {"commands": 10**400}}, "'human_effort.total.commands'"),
    ("human_effort", {"total": {"corrections": -1}}, "'human_effort.total.corrections'"),
]


@pytest.mark.parametrize(("key", "value", "problem"), DAMAGED, ids=[p for _, _, p in DAMAGED])
def test_damaged_results_are_refused_naming_the_file(stored, key, value, problem):
    study, out, job, path = stored
    text = json.dumps(_with(job_results(job), key, value))
    path.write_text(text)
    for action in (lambda: run_study(study, out), lambda: load_finished(study, out)):
        with pytest.raises(FileFormatError) as exc:
            action()
        message = str(exc.value)
        assert "\n" not in message and message.startswith(f"{path}: "), message
        assert problem in message and "delete" in message, message
    assert path.read_text() == text  # the user's file is kept as it was
    assert not (out / study.jobs()[1].key).exists()  # and no other job ran


def _json_with(results: dict, key: str, value: object, raw: str) -> str:
    """results.json text with ``results[key] = value`` whose JSON number is replaced by ``raw``."""
    return json.dumps({**results, key: value}).replace("123.25", raw)


RAW = [
    # Nested far deeper than the JSON parser recurses.
    ("deep", lambda r: _json_with(r, "x", 123.25, "[" * 100_000 + "]" * 100_000), "nested"),
    ("5000 digits", lambda r: _json_with(r, "x", 123.25, "7" * 5000), "unreadable"),
    ("infinity", lambda r: _json_with(r, "timing_s", {"wall": 123.25}, "1e999"), "finite"),
    ("NaN", lambda r: _json_with(r, "training_accuracy", [123.25], "NaN"), "finite"),
    ("not an object", lambda r: "[1, 2]", "other settings"),
]


@pytest.mark.parametrize(("name", "make", "problem"), RAW, ids=[n for n, _, _ in RAW])
def test_unparsable_results_are_refused_in_one_line(stored, name, make, problem):
    study, out, job, path = stored
    text = make(job_results(job))
    path.write_text(text)
    with pytest.raises(FileFormatError) as exc:
        run_study(study, out)
    message = str(exc.value)
    assert "\n" not in message and message.startswith(f"{path}: "), message
    assert problem in message, message
    assert path.read_text() == text


def test_results_json_that_is_not_a_regular_file_is_refused(stored):
    study, out, job, path = stored
    path.mkdir()  # a folder where the results should be: not "unfinished", not overwritten
    with pytest.raises(FileFormatError, match="is a folder"):
        run_study(study, out)
    path.rmdir()
    if hasattr(os, "mkfifo"):
        os.mkfifo(path)  # a FIFO would block a plain read forever
        with pytest.raises(FileFormatError, match="not a regular file"):
            finished_results(out, job)


def test_valid_hand_written_results_are_accepted_and_pooled(stored):
    study, out, job, path = stored
    for j in study.jobs():
        (out / j.key).mkdir(parents=True, exist_ok=True)
        (out / j.key / RESULTS_FILE).write_text(json.dumps(job_results(j)))
    assert run_study(study, out).ran == 0
    summary = build_study_results(study, load_finished(study, out))
    (c,) = summary["conditions"]
    assert (c["testing"]["successes"], c["testing"]["trials"]) == (2, 4)
    assert c["human_commands"]["total"] == 2 * (150 + 10)


def test_cli_refuses_a_damaged_result_in_one_line_and_keeps_everything(stored, capsys):
    study, out, job, path = stored
    text = json.dumps(_with(job_results(job), "outcomes", [{}]))
    path.write_text(text)
    assert main(["--quiet", "study", study.source, "--out", str(out)]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"lfd-track study: {path}: "), err
    assert "Traceback" not in err
    assert path.read_text() == text
    assert sorted(p.name for p in out.iterdir()) == [job.condition]  # no study.json, no job ran
    assert [p.name for p in (out / job.condition).iterdir()] == [f"seed{job.seed}"]


REPO = Path(__file__).resolve().parents[2]
COMMITTED = sorted(p.parent for p in (REPO / "benchmarks").rglob("study.json"))


def test_there_are_committed_studies():
    assert len(COMMITTED) >= 1


@pytest.mark.parametrize("folder", COMMITTED, ids=[p.name for p in COMMITTED])
def test_committed_studies_are_accepted_and_pool_as_committed(folder, monkeypatch):
    """Every committed study's job results pass the resume checks and pool to the committed
    totals (the trial checks refuse no honest run)."""
    committed = json.loads((folder / "study.json").read_text(encoding="utf-8"))
    # A study file X.toml keeps its results in results/X/ beside it (or a copy further down,
    # e.g. results/bilinear/X/): the nearest X.toml above the folder (names repeat elsewhere).
    name = f"{committed['study']}.toml"
    source = next(p / name for p in folder.parents if (p / name).is_file())
    monkeypatch.chdir(REPO)  # as the studies were run (a demo_track is kept as it was given)
    study = load_study(source.relative_to(REPO))
    pooled = build_study_results(study, load_finished(study, folder))

    def totals(summary):
        return [
            (c["name"], c[track]["successes"], c[track]["trials"])
            for c in summary["conditions"]
            for track in ("training", "testing")
        ]

    assert totals(pooled) == totals(committed)
