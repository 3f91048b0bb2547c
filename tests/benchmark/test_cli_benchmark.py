"""``lfd-track benchmark``: every track is checked against the preset before anything runs, absurd
numbers are refused at once, and a run that fails at any point leaves the previous output in its
folder byte for byte (nothing already saved is lost)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest
from lfd_test_support import snapshot

from lfd_track.benchmark import report, runner
from lfd_track.cli import main

ROOT = Path(__file__).resolve().parents[2]

BIG_LOOP = """name = "big"
closed = true
width_m = 0.30
vertices = [[0.0, 0.0], [6.0, 0.0], [6.0, 6.0], [0.0, 6.0]]

[corners]
"A" = 0
"B" = 1
"C" = 2
"D" = 3
"""

LOOP_WITHOUT_CORNERS = """name = "plain"
closed = true
width_m = 0.30
vertices = [[0.0, 0.0], [3.0, 0.0], [3.0, 1.8], [0.0, 1.8]]
"""


def preset_with_margin(folder: Path, margin_m: float) -> Path:
    """The paper preset with a wider carpet margin around the felt."""
    text = (ROOT / "envs" / "paper.toml").read_text(encoding="utf-8")
    text = text.replace("[appearance]\n", f"[appearance]\nmargin_m = {margin_m}\n", 1)
    path = folder / f"margin{margin_m:g}.toml"
    path.write_text(text, encoding="utf-8")
    return path


def quick(out: Path, *extra: str) -> list[str]:
    return ["--quiet", "benchmark", "--quick", "--workers", "1", *extra, "--out", str(out)]


@pytest.fixture(scope="module")
def previous_run(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("previous") / "b_out"
    assert main(quick(out)) == 0
    return out


@pytest.fixture
def old_output(previous_run, tmp_path) -> Path:
    """A copy of a good quick run (and a file of the user's) in a folder of its own."""
    out = tmp_path / "runs" / "b_out"
    shutil.copytree(previous_run, out)
    (out / "notes.txt").write_text("mine")
    return out


class Untouched:
    """Remembers an output folder and what lies beside it."""

    def __init__(self, out: Path) -> None:
        self.out, self.before, self.around = out, snapshot(out), sorted(os.listdir(out.parent))

    def check(self) -> None:
        assert snapshot(self.out) == self.before
        assert sorted(os.listdir(self.out.parent)) == self.around  # no staging folder left


def one_line_error(capsys) -> str:
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("lfd-track benchmark: "), err
    return err


@pytest.fixture
def must_not_run(monkeypatch):
    def fail(*args, **kwargs):
        raise AssertionError("the benchmark ran although a track could not be driven")

    monkeypatch.setattr(runner, "run_benchmark", fail)


# ------------------------------------------------------------------------ up-front track checks
def test_a_test_loop_too_big_for_the_ground_texture_fails_before_anything_runs(
    old_output, tmp_path, capsys, must_not_run
):
    preset = preset_with_margin(tmp_path, 2)
    loop = tmp_path / "big.toml"
    loop.write_text(BIG_LOOP)
    kept = Untouched(old_output)
    argv = quick(old_output, "--preset", str(preset), "--test-track", str(loop))
    assert main(argv) == 1
    err = one_line_error(capsys)
    assert str(loop) in err and "ground texture" in err and str(preset) in err
    kept.check()


def test_a_training_track_too_big_for_the_ground_texture_fails_before_anything_runs(
    old_output, tmp_path, capsys, must_not_run
):
    preset = preset_with_margin(tmp_path, 5)
    kept = Untouched(old_output)
    assert main(quick(old_output, "--preset", str(preset))) == 1
    err = one_line_error(capsys)
    assert "track 'training'" in err and "ground texture" in err and str(preset) in err
    kept.check()


def test_a_test_loop_without_corners_fails_before_anything_runs(
    old_output, tmp_path, capsys, must_not_run
):
    loop = tmp_path / "plain.toml"
    loop.write_text(LOOP_WITHOUT_CORNERS)
    kept = Untouched(old_output)
    assert main(quick(old_output, "--test-track", str(loop))) == 1
    err = one_line_error(capsys)
    assert str(loop) in err and "no corners" in err
    kept.check()


def test_a_bad_track_into_a_new_folder_creates_nothing(tmp_path, capsys, must_not_run):
    loop = tmp_path / "plain.toml"
    loop.write_text(LOOP_WITHOUT_CORNERS)
    out = tmp_path / "fresh" / "b_out"
    assert main(quick(out, "--test-track", str(loop))) == 1
    one_line_error(capsys)
    assert not (tmp_path / "fresh").exists()


# ------------------------------------------------------------------- failures late in the run
def _trial_fails(*args, **kwargs):
    raise ValueError("simulated failure in an autonomous trial")


def _disk_full_for_the_report(*args, **kwargs):
    raise OSError(28, "No space left on device", "report.md")


@pytest.mark.parametrize(
    ("module", "name", "broken", "shown"),
    [
        (runner, "run_trial", _trial_fails, "simulated failure"),
        (report, "write_report_from_results", _disk_full_for_the_report, "No space left on device"),
    ],
    ids=["in the trials", "while writing the report"],
)
def test_a_late_failure_leaves_the_previous_output(
    old_output, capsys, monkeypatch, module, name, broken, shown
):
    monkeypatch.setattr(module, name, broken)
    kept = Untouched(old_output)
    assert main(quick(old_output)) == 1
    assert shown in one_line_error(capsys)
    kept.check()


def test_a_real_failure_at_trial_time_leaves_the_previous_output(
    old_output, tmp_path, capsys, monkeypatch
):
    """End to end: with the up-front check switched off, the too-big test loop fails for real
    when its trials start, after a whole repetition has learned and driven the other tracks."""
    monkeypatch.setattr(runner, "check_tracks", lambda config: None)
    preset = preset_with_margin(tmp_path, 2)
    loop = tmp_path / "big.toml"
    loop.write_text(BIG_LOOP)
    kept = Untouched(old_output)
    assert main(quick(old_output, "--preset", str(preset), "--test-track", str(loop))) == 1
    assert "ground texture" in one_line_error(capsys)
    kept.check()


def _without_timing(path: Path) -> dict:
    data = json.loads(path.read_text())
    data.pop("timing_s")
    return data


def test_a_successful_rerun_replaces_the_output_in_the_same_layout(old_output, previous_run):
    stale = old_output / "repetitions" / "rep_03"
    stale.mkdir()
    (stale / "controller.json").write_text("from a longer earlier run")
    before = snapshot(old_output)
    assert main(quick(old_output)) == 0
    after = snapshot(old_output)
    assert set(after) == set(before)
    assert _without_timing(old_output / "results.json") == _without_timing(
        previous_run / "results.json"
    )
    for name in ("controller.json", "demonstration.lfdemo"):
        rel = f"repetitions/rep_00/{name}"
        assert after[rel][0] == before[rel][0]  # the same seed gives the same files
    assert after["notes.txt"] == before["notes.txt"]
    assert (
        after["repetitions/rep_03/controller.json"] == before["repetitions/rep_03/controller.json"]
    )
    assert sorted(os.listdir(old_output.parent)) == ["b_out"]


# ------------------------------------------------------------------------------ absurd numbers
@pytest.mark.parametrize(
    ("flag", "value"),
    [
        ("--repetitions", "1000000000000"),
        ("--repetitions", "10001"),
        ("--trials", "1000000000000"),
        ("--seed", "4294967296"),
        ("--seed", "1" + "0" * 400),
        ("--workers", "1000000000000"),
        ("--random-loops", "10001"),
    ],
)
def test_absurd_numbers_are_refused_at_once_naming_the_flag(
    tmp_path, capsys, must_not_run, flag, value
):
    out = tmp_path / "b_out"
    with pytest.raises(SystemExit) as exited:
        main(["--quiet", "benchmark", flag, value, "--out", str(out)])
    assert exited.value.code != 0
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and flag in err and "must be at most" in err, err
    assert len(err) < 300, err
    assert not out.exists()


def test_a_trillion_repetitions_do_not_hang(tmp_path):
    start = time.perf_counter()
    proc = subprocess.run(
        [sys.executable, "-m", "lfd_track.cli", "--quiet", "benchmark", "--repetitions"]
        + ["1000000000000", "--out", str(tmp_path / "b_out")],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert proc.returncode != 0 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert "--repetitions" in proc.stderr and time.perf_counter() - start < 30
    assert not (tmp_path / "b_out").exists()


# ------------------------------------------------------------------------------------ SIGTERM
SIGTERM_MID_RUN = """
import os, signal, sys
from lfd_track.benchmark import runner
from lfd_track.cli import main

def killed(config, work_dir, **kwargs):
    os.makedirs(os.path.join(work_dir, "rep_00"))
    open(os.path.join(work_dir, "rep_00", "demonstration.lfdemo"), "w").write("half")
    os.kill(os.getpid(), signal.SIGTERM)
    raise AssertionError("SIGTERM did not stop the run")

runner.run_benchmark = killed
sys.exit(main(sys.argv[1:]))
"""


def test_sigterm_leaves_the_previous_output_and_no_staging_folder(old_output):
    kept = Untouched(old_output)
    proc = subprocess.run(
        [sys.executable, "-c", SIGTERM_MID_RUN, *quick(old_output)],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=ROOT,
    )
    assert proc.returncode == 143, proc.stderr
    assert proc.stderr.count("\n") == 1 and "Traceback" not in proc.stderr, proc.stderr
    assert f"interrupted; {old_output} is as it was" in proc.stderr
    kept.check()
