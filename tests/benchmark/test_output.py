"""A benchmark's output folder changes only when a run has succeeded (benchmark/output.py)."""

from __future__ import annotations

import os
import stat
from pathlib import Path

import pytest
from lfd_test_support import snapshot

from lfd_track.benchmark import output
from lfd_track.benchmark.output import staged_output


def write_run(folder: Path, tag: str, reps: int = 2) -> None:
    """What a benchmark run leaves: per-repetition files, plots, report, results."""
    for r in range(reps):
        rep = folder / "repetitions" / f"rep_{r:02d}"
        rep.mkdir(parents=True)
        (rep / "controller.json").write_text(f"{tag} controller {r}")
        (rep / "demonstration.lfdemo").write_text(f"{tag} demo {r}")
    for name in ("trajectories.png", "fitness.png", "report.md", "results.json"):
        (folder / name).write_text(f"{tag} {name}")


@pytest.fixture
def previous(tmp_path) -> Path:
    out = tmp_path / "b_out"
    write_run(out, "old", reps=3)
    (out / "repetitions" / "rep_01" / "interventions_r0.lfdemo").write_text("old extra")
    (out / "notes.txt").write_text("the user's own file")
    return out


def test_a_failed_run_leaves_the_previous_output_and_nothing_beside_it(previous):
    before, around = snapshot(previous), sorted(os.listdir(previous.parent))
    with pytest.raises(RuntimeError, match="trial failed"), staged_output(previous) as stage:
        write_run(stage, "new")
        raise RuntimeError("trial failed")
    assert snapshot(previous) == before
    assert sorted(os.listdir(previous.parent)) == around


def test_an_interrupted_run_leaves_the_previous_output(previous):
    before = snapshot(previous)
    with pytest.raises(KeyboardInterrupt), staged_output(previous) as stage:
        (stage / "repetitions" / "rep_00").mkdir(parents=True)
        raise KeyboardInterrupt
    assert snapshot(previous) == before
    assert sorted(os.listdir(previous.parent)) == ["b_out"]


def test_a_failed_first_run_creates_nothing(tmp_path):
    out = tmp_path / "new" / "deeper" / "b_out"
    with pytest.raises(ValueError), staged_output(out) as stage:
        write_run(stage, "new")
        raise ValueError("bad")
    assert os.listdir(tmp_path) == []


def test_a_successful_run_replaces_what_it_writes_and_keeps_the_rest(previous):
    with staged_output(previous) as stage:
        assert stage.parent == previous.parent and stage.name.startswith(".")
        write_run(stage, "new", reps=2)
    for r in (0, 1):
        rep = previous / "repetitions" / f"rep_{r:02d}"
        assert sorted(os.listdir(rep)) == ["controller.json", "demonstration.lfdemo"]
        assert (rep / "controller.json").read_text() == f"new controller {r}"
    assert (previous / "results.json").read_text() == "new results.json"
    assert (previous / "report.md").read_text() == "new report.md"
    # Not written by this run: left as they were (as before outputs were staged).
    assert (
        previous / "repetitions" / "rep_02" / "controller.json"
    ).read_text() == "old controller 2"
    assert (previous / "notes.txt").read_text() == "the user's own file"
    assert sorted(os.listdir(previous.parent)) == ["b_out"]


def test_a_first_run_becomes_the_output_folder_with_ordinary_permissions(tmp_path):
    out = tmp_path / "sub" / "b_out"
    with staged_output(out) as stage:
        write_run(stage, "new", reps=1)
    assert (out / "results.json").read_text() == "new results.json"
    assert (out / "repetitions" / "rep_00" / "controller.json").is_file()
    mask = os.umask(0)
    os.umask(mask)
    assert stat.S_IMODE(out.stat().st_mode) == 0o777 & ~mask
    assert sorted(os.listdir(out.parent)) == ["b_out"]


def test_a_failure_while_replacing_puts_every_old_file_back(previous, monkeypatch):
    before = snapshot(previous)
    real_rename = os.rename
    calls, failed = [], []

    def flaky_rename(src, dst):
        calls.append((src, dst))
        if Path(dst) == previous / "report.md" and not failed:
            failed.append(dst)
            raise OSError(28, "No space left on device", str(dst))
        return real_rename(src, dst)

    monkeypatch.setattr(output.os, "rename", flaky_rename)
    with pytest.raises(OSError, match="No space"), staged_output(previous) as stage:
        write_run(stage, "new", reps=2)
    assert len(calls) > 4  # repetitions and plots had already been swapped in
    assert snapshot(previous) == before
    assert sorted(os.listdir(previous.parent)) == ["b_out"]


def test_an_output_that_is_a_file_is_refused_before_the_run(tmp_path):
    out = tmp_path / "b_out"
    out.write_text("a file")
    with pytest.raises(Exception, match="not a folder"), staged_output(out):
        raise AssertionError("the run must not start")
    assert out.read_text() == "a file"
