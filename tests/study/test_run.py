"""Running a study: one results file per job, resumable, pooled correctly, quiet when piped."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys

import pytest
from study_helpers import TINY_STUDY, job_results, write_study

from lfd_track.benchmark.runner import BenchmarkConfig, config_dict
from lfd_track.errors import FileFormatError, LfdTrackError
from lfd_track.learning.ga import GAConfig
from lfd_track.study.jobs import RESULTS_FILE
from lfd_track.study.run import run_study
from lfd_track.study.spec import Job, load_study
from lfd_track.study.stats import wilson_interval


def without_timing(results: dict) -> dict:
    return {k: v for k, v in results.items() if k != "timing_s"}


def test_each_job_is_one_paper_protocol_benchmark_with_its_own_results(tiny_study):
    path, out, run = tiny_study
    assert (run.total, run.skipped, run.ran) == (2, 0, 2)
    for seed in (0, 1):
        results = json.loads((out / "paper" / f"seed{seed}" / RESULTS_FILE).read_text())
        assert results["config"]["seed"] == seed and results["config"]["repetitions"] == 1
        assert results["config"]["ga"]["generations"] == 5
        assert len(results["outcomes"]) == 4  # one trial in each of the four directions
        assert (out / "paper" / f"seed{seed}" / "report.md").is_file()


def test_study_json_pools_the_jobs_with_wilson_intervals(tiny_study):
    _, out, _ = tiny_study
    summary = json.loads((out / "study.json").read_text())
    (condition,) = summary["conditions"]
    assert {"name", "method", "preset", "seeds", "repetitions", "training", "testing"} <= set(
        condition
    )
    assert (condition["name"], condition["method"], condition["preset"]) == (
        "paper",
        "paper",
        "paper",
    )
    assert condition["seeds"] == [0, 1] and condition["repetitions"] == 1
    jobs = [json.loads((out / "paper" / f"seed{s}" / RESULTS_FILE).read_text()) for s in (0, 1)]
    for track, key, trials_key in (
        ("training", "training_track", "trials"),
        ("testing", "testing_track", "laps"),
    ):
        successes = sum(j[key]["successes"] for j in jobs)
        trials = sum(j[key][trials_key] for j in jobs)
        low, high = wilson_interval(successes, trials)
        assert condition[track]["successes"] == successes and condition[track]["trials"] == trials
        assert condition[track]["ci95"] == [
            pytest.approx(low, abs=1e-6),
            pytest.approx(high, abs=1e-6),
        ]
        # Per-corner failures agree with the benchmark's own corner tables.
        directions = [v for j in jobs for v in j[key].values() if isinstance(v, dict)]
        for corner, failures in condition["corner_failures"][track].items():
            assert failures == sum(d["corners"][corner]["failures"] for d in directions)
    demo_commands = sum(d["cases"] + 10 for j in jobs for d in j["demonstrations"])
    assert condition["human_commands"]["total"] == demo_commands
    assert condition["wall_s"] == pytest.approx(sum(j["timing_s"]["wall"] for j in jobs), abs=1e-5)
    assert (
        summary["paper"]["testing"]["successes"] == 28
        and summary["paper"]["testing"]["trials"] == 60
    )
    table = (out / "study.md").read_text()
    assert "| paper | paper | paper |" in table and "28/60 = 47 % [35–59]" in table
    assert (out / "study.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_rerun_skips_finished_jobs_and_reruns_only_missing_ones(tiny_study, tmp_path):
    path, out, _ = tiny_study
    copy = tmp_path / "out"
    shutil.copytree(out, copy)
    study = load_study(path)
    seed0 = (copy / "paper" / "seed0" / RESULTS_FILE).read_bytes()
    assert run_study(study, copy).ran == 0
    # An interrupted job leaves at most a report without results: it is run again, alone
    # (here in a worker process of the local pool).
    (copy / "paper" / "seed1" / RESULTS_FILE).unlink()
    run = run_study(study, copy, workers=2)
    assert (run.skipped, run.ran) == (1, 1)
    assert (copy / "paper" / "seed0" / RESULTS_FILE).read_bytes() == seed0  # untouched
    rerun = json.loads((copy / "paper" / "seed1" / RESULTS_FILE).read_text())
    first = json.loads((out / "paper" / "seed1" / RESULTS_FILE).read_text())
    assert without_timing(rerun) == without_timing(first)  # same seed, same results


def test_changed_settings_under_an_old_name_are_refused(tiny_study, tmp_path):
    _, out, _ = tiny_study
    copy = tmp_path / "out"
    shutil.copytree(out, copy)
    changed = write_study(tmp_path, TINY_STUDY.replace("generations = 5", "generations = 6"))
    with pytest.raises(FileFormatError, match="other settings than condition 'paper'"):
        run_study(load_study(changed), copy)
    (copy / "paper" / "seed0" / RESULTS_FILE).write_text("{not json")
    with pytest.raises(FileFormatError, match="unreadable results"):
        run_study(load_study(write_study(tmp_path)), copy)


def test_a_study_file_moved_beside_its_preset_keeps_its_results(tmp_path):
    # Written in planned/ (preset "../presets/p.toml"), run, then moved out beside presets/
    # (preset "presets/p.toml"): the same file, so its finished jobs are its own.
    from lfd_track.study.jobs import expected_config, finished_results, job_folder, same_settings

    (tmp_path / "presets").mkdir()
    (tmp_path / "presets" / "p.toml").write_text('name = "p"\n')
    (tmp_path / "planned").mkdir()
    planned = write_study(
        tmp_path / "planned", TINY_STUDY.replace('preset = "paper"', 'preset = "../presets/p.toml"')
    )
    job = load_study(planned).jobs()[0]
    assert "/planned/" not in job.config.preset  # read in its normal form
    stored = {**expected_config(job), "preset": str(tmp_path / "planned/../presets/p.toml")}
    folder = job_folder(tmp_path / "out", job)
    folder.mkdir(parents=True)
    (folder / RESULTS_FILE).write_text(json.dumps({**job_results(job), "config": stored}))
    moved = write_study(
        tmp_path, TINY_STUDY.replace('preset = "paper"', 'preset = "presets/p.toml"')
    )
    assert finished_results(tmp_path / "out", load_study(moved).jobs()[0]) is not None
    other = {**stored, "preset": str(tmp_path / "presets/q.toml")}
    assert not same_settings(other, expected_config(job))


def test_cli_is_quiet_when_piped_and_prints_the_summary(tiny_study):
    path, out, _ = tiny_study
    done = subprocess.run(
        [sys.executable, "-m", "lfd_track.cli", "study", str(path), "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    assert done.stderr == ""  # piped: no progress bar
    assert "paper: testing" in done.stdout and "0 jobs run, 2 already finished" in done.stdout


def test_progress_shows_jobs_done_of_total(tiny_study, tmp_path, capsys):
    path, out, _ = tiny_study
    copy = tmp_path / "out"
    shutil.copytree(out, copy)
    run_study(load_study(path), copy, progress=True)
    assert "2/2" in capsys.readouterr().err
    # With a job left to run, the bar counts it and shows elapsed<remaining time (the ETA).
    (copy / "paper" / "seed1" / "results.json").unlink()
    run_study(load_study(path), copy, progress=True)
    err = capsys.readouterr().err
    assert "1/2" in err and re.search(r"2/2 \[\d\d:\d\d<\d\d:\d\d", err), err


@pytest.mark.parametrize("workers", [1, 2])
def test_a_failing_job_names_itself(workers):
    from lfd_track.study.run import _run_local

    job = Job(
        condition="broken",
        seed=0,
        config=BenchmarkConfig(repetitions=1, preset="no-such-preset", ga=GAConfig(generations=1)),
    )
    assert config_dict(job.config)["preset"] == "no-such-preset"
    with pytest.raises(LfdTrackError, match="job broken/seed0 failed: unknown preset"):
        _run_local([job, job], lambda job, files: None, workers=workers)


def test_an_interrupt_keeps_finished_jobs_and_the_rerun_does_only_the_rest(tmp_path, monkeypatch):
    import lfd_track.study.run as run_module

    study = load_study(write_study(tmp_path))
    first, second = study.jobs()
    calls = []

    def fake_job(job):
        calls.append(job.key)
        if job == second and len(calls) == 2:
            raise KeyboardInterrupt  # Ctrl-C while the second job runs
        results = json.dumps(job_results(job))
        return {"report.md": b"report\n", RESULTS_FILE: results.encode()}

    monkeypatch.setattr(run_module, "run_job", fake_job)
    out = tmp_path / "out"
    with pytest.raises(KeyboardInterrupt):
        run_study(study, out)
    assert (out / first.key / RESULTS_FILE).is_file()
    assert not (out / second.key).exists()
    run = run_study(study, out)
    assert (run.skipped, run.ran) == (1, 1) and calls == [first.key, second.key, second.key]


SIGTERM_IN_SECOND_JOB = """
import json, os, signal, sys
sys.path.insert(0, sys.argv[1])
from study_helpers import job_results
import lfd_track.study.run as run_module
from lfd_track.cli import main

calls = []

def fake_job(job):
    calls.append(job.key)
    if len(calls) == 2:
        os.kill(os.getpid(), signal.SIGTERM)  # stopped while the second job runs
        raise AssertionError("SIGTERM did not stop the study")
    return {"report.md": b"report\\n", "results.json": json.dumps(job_results(job)).encode()}

run_module.run_job = fake_job
sys.exit(main(sys.argv[2:]))
"""


def test_sigterm_stops_the_study_in_one_line_and_keeps_finished_jobs(tmp_path):
    from pathlib import Path

    path = write_study(tmp_path)
    out = tmp_path / "out"
    here = Path(__file__).parent
    done = subprocess.run(
        [sys.executable, "-c", SIGTERM_IN_SECOND_JOB, str(here), "study", str(path)]
        + ["--out", str(out)],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=here.parents[1],
    )
    assert done.returncode == 143, done.stderr
    assert done.stderr.count("\n") == 1 and "interrupted" in done.stderr, done.stderr
    first, second = load_study(path).jobs()
    assert (out / first.key / RESULTS_FILE).is_file()
    assert sorted(p.name for p in out.rglob("*")) == ["paper", "report.md", "results.json", "seed0"]
