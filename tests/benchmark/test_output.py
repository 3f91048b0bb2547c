"""A benchmark's output folder changes only when a run has succeeded (utils/staging.py)."""

from __future__ import annotations

import contextlib
import os
import signal
import stat
from pathlib import Path

import pytest
from lfd_test_support import snapshot

from lfd_track.utils import staging as output
from lfd_track.utils.staging import staged_output


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


def _replaced_whole(out: Path) -> bool:
    """Whether ``out`` holds the "new" run of two repetitions over ``previous``, entirely."""
    return (
        all(
            (out / "repetitions" / f"rep_{r:02d}" / "controller.json").read_text()
            == f"new controller {r}"
            and not (out / "repetitions" / f"rep_{r:02d}" / "interventions_r0.lfdemo").exists()
            for r in (0, 1)
        )
        and all((out / n).read_text() == f"new {n}" for n in ("report.md", "results.json"))
        and (out / "repetitions" / "rep_02" / "controller.json").read_text() == "old controller 2"
    )


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_signals_while_replacing_never_lose_the_previous_output(previous, monkeypatch, signum):
    """Ctrl-C (or SIGTERM) in the middle of the moves, and again while they would be undone:
    the output folder ends up old or new, whole, never with old entries deleted."""
    before = snapshot(previous)
    real_rename = os.rename
    renames = 0

    def rename(src, dst):
        nonlocal renames
        renames += 1
        if renames in (3, 4):
            os.kill(os.getpid(), signum)
        return real_rename(src, dst)

    def interrupted(signum, frame):
        raise KeyboardInterrupt

    monkeypatch.setattr(output.os, "rename", rename)
    previous_handler = signal.signal(signum, interrupted)
    try:
        with contextlib.suppress(KeyboardInterrupt), staged_output(previous) as stage:
            write_run(stage, "new", reps=2)
    finally:
        signal.signal(signum, previous_handler)
    assert snapshot(previous) == before or _replaced_whole(previous)
    assert sorted(os.listdir(previous.parent)) == ["b_out"]


def _stale_stage(out: Path, name: str = ".b_out.benchmark-k1ll3d0a") -> Path:
    """A staging folder as a killed run leaves it (an hour old, nobody holding it)."""
    stage = out.parent / name
    write_run(stage, "killed", reps=1)
    hour_ago = stage.stat().st_mtime - 3600
    os.utime(stage, (hour_ago, hour_ago))
    return stage


@pytest.mark.parametrize("fails", [False, True])
def test_the_next_run_removes_a_staging_folder_a_killed_run_left(previous, fails):
    _stale_stage(previous)
    before = snapshot(previous)
    with contextlib.suppress(RuntimeError), staged_output(previous) as stage:
        write_run(stage, "new", reps=2)
        if fails:
            raise RuntimeError("trial failed")
    assert sorted(os.listdir(previous.parent)) == ["b_out"]
    assert snapshot(previous) == before if fails else _replaced_whole(previous)


def test_the_staging_folder_of_a_run_still_going_is_left_alone(previous):
    with staged_output(previous) as running:
        (running / "report.md").write_text("still running")
        hour_ago = running.stat().st_mtime - 3600
        os.utime(running, (hour_ago, hour_ago))
        with staged_output(previous) as stage:
            write_run(stage, "new", reps=2)
        assert (running / "report.md").read_text() == "still running"
    assert (previous / "report.md").read_text() == "still running"
    assert sorted(os.listdir(previous.parent)) == ["b_out"]


def test_a_left_staging_folder_holding_old_entries_is_kept(previous):
    """A run killed while replacing had moved old entries aside: they are never deleted."""
    stage = _stale_stage(previous)
    aside = stage / ".previous-abc" / "0"
    aside.mkdir(parents=True)
    (aside / "controller.json").write_text("old entry moved aside")
    with staged_output(previous) as new:
        write_run(new, "new", reps=1)
    assert (aside / "controller.json").read_text() == "old entry moved aside"


def test_moves_into_the_output_are_not_interleaved_with_another_run(previous, monkeypatch):
    fcntl = pytest.importorskip("fcntl")
    real_rename = os.rename
    held = []

    def rename(src, dst):
        fd = os.open(previous, os.O_RDONLY)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            held.append(False)
        except BlockingIOError:
            held.append(True)
        finally:
            os.close(fd)
        return real_rename(src, dst)

    monkeypatch.setattr(output.os, "rename", rename)
    with staged_output(previous) as stage:
        write_run(stage, "new", reps=2)
    assert held and all(held)
    assert _replaced_whole(previous)
