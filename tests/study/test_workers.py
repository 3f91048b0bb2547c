"""A study's worker processes: a killed worker, a killed study, two studies into one folder.

Every study here runs in a subprocess with scripted jobs (:mod:`scripted_jobs`): a job takes
milliseconds or, when told to, waits to be killed, so the tests can kill a worker (or the study
itself) in the middle of a job. Waits poll with a deadline; a subprocess left behind by a failed
test is killed with its whole process group.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from scripted_jobs import BLOCK, SCRIPT_DIR, SCRIPTED_MAIN, attempt_file
from study_helpers import TINY_STUDY, write_study

from lfd_track.study.jobs import RESULTS_FILE

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]
THREE_SEEDS = TINY_STUDY.replace("seeds = [0, 1]", "seeds = [0, 1, 2]")

pytestmark = pytest.mark.skipif(os.name != "posix", reason="kills processes with POSIX signals")


@pytest.fixture
def studies():
    """Start ``lfd-track study`` subprocesses with scripted jobs; all are killed at the end."""
    started: list[subprocess.Popen] = []

    def start(study: Path, out: Path, folder: Path, *extra: str, block: str = ""):
        folder.mkdir(exist_ok=True)
        env = {
            **os.environ,
            "PYTHONPATH": os.pathsep.join([str(HERE), str(REPO)]),
            SCRIPT_DIR: str(folder),
            BLOCK: block,
        }
        args = ["--quiet", "study", str(study), "--out", str(out), *extra]
        proc = subprocess.Popen(
            [sys.executable, "-c", SCRIPTED_MAIN, *args],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            cwd=REPO,
            env=env,
            start_new_session=True,  # its own process group, so clean-up reaches every worker
        )
        started.append(proc)
        return proc

    yield start
    for proc in started:
        try:
            os.killpg(proc.pid, signal.SIGKILL)
        except OSError:
            pass
        proc.communicate()


def wait_for(what: str, predicate, timeout: float = 60.0):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = predicate()
        if value:
            return value
        time.sleep(0.02)
    raise AssertionError(f"timed out waiting for {what}")


def attempt_pid(folder: Path, key: str, attempt: int = 1, timeout: float = 60.0) -> int:
    """The pid of the process running ``attempt`` of job ``key``, once it has started."""
    path = attempt_file(folder, key, attempt)
    wait_for(f"attempt {attempt} of {key}", path.exists, timeout)
    return int(path.read_text())


def alive(pid: int) -> bool:
    """Whether ``pid`` runs (a zombie, dead but not yet reaped by its new parent, does not)."""
    try:
        with open(f"/proc/{pid}/stat", encoding="ascii") as stat:
            return stat.read().rsplit(")", 1)[1].split()[0] != "Z"
    except FileNotFoundError:
        return False
    except OSError:  # no /proc
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return False
        return True


def descendants(pid: int) -> set[int]:
    """Every process below ``pid`` (from /proc; empty where there is none)."""
    parents: dict[int, int] = {}
    for entry in Path("/proc").glob("[0-9]*"):
        try:
            fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
            parents[int(entry.name)] = int(fields[2])
        except (OSError, ValueError, IndexError):
            continue
    found, frontier = set(), {pid}
    while frontier:
        frontier = {child for child, parent in parents.items() if parent in frontier} - found
        found |= frontier
    return found


def finished(out: Path, seeds) -> list[int]:
    return [s for s in seeds if (out / "paper" / f"seed{s}" / RESULTS_FILE).is_file()]


def test_a_killed_worker_s_job_runs_again_and_the_study_finishes(tmp_path, studies):
    study, out, folder = write_study(tmp_path, THREE_SEEDS), tmp_path / "out", tmp_path / "jobs"
    proc = studies(study, out, folder, "--workers", "2", block="paper/seed1:1")
    os.kill(attempt_pid(folder, "paper/seed1"), signal.SIGKILL)
    stdout, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 0, stderr
    assert finished(out, (0, 1, 2)) == [0, 1, 2]
    assert attempt_file(folder, "paper/seed1", 2).exists()  # run again, once
    assert "3 jobs run (1 again after its worker process died)" in stdout, stdout
    assert (out / "study.json").is_file()


def test_a_job_whose_worker_dies_twice_fails_in_one_line_after_the_rest(tmp_path, studies):
    study, out, folder = write_study(tmp_path, THREE_SEEDS), tmp_path / "out", tmp_path / "jobs"
    proc = studies(study, out, folder, "--workers", "2", block="paper/seed1:2")
    os.kill(attempt_pid(folder, "paper/seed1", 1), signal.SIGKILL)
    os.kill(attempt_pid(folder, "paper/seed1", 2), signal.SIGKILL)
    _, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 1, stderr
    assert stderr.count("\n") == 1 and "Traceback" not in stderr, stderr
    assert stderr.startswith("lfd-track study: job paper/seed1 failed: its worker process died")
    assert "SIGKILL" in stderr, stderr
    assert finished(out, (0, 1, 2)) == [0, 2]  # the other jobs ran to the end and are kept
    assert not (out / "study.json").exists()
    # Rerunning resumes: only the failed job runs.
    rerun = studies(study, out, folder, "--workers", "2")
    stdout, stderr = rerun.communicate(timeout=60)
    assert rerun.returncode == 0, stderr
    assert "1 jobs run, 2 already finished" in stdout, stdout
    assert finished(out, (0, 1, 2)) == [0, 1, 2]


def _tree(out: Path) -> dict[str, bytes | None]:
    return {
        str(p.relative_to(out)): p.read_bytes() if p.is_file() else None
        for p in sorted(out.rglob("*"))
    }


@pytest.mark.parametrize("workers", ["1", "2"])
def test_a_second_study_into_a_busy_folder_is_refused_in_one_line(tmp_path, studies, workers):
    study, out = write_study(tmp_path), tmp_path / "out"
    first = studies(study, out, tmp_path / "first", "--workers", workers, block="paper/seed0:1")
    attempt_pid(tmp_path / "first", "paper/seed0")  # the first study is running a job
    wait_for("the first study's finished job", lambda: workers == "1" or finished(out, (1,)))
    before = _tree(out)
    other_text = TINY_STUDY.replace("generations = 5", "generations = 6")
    other = write_study(tmp_path, other_text, "other.toml")
    for second_study in (study, other):  # the same study, and one with other settings
        second = studies(second_study, out, tmp_path / "second", "--workers", workers)
        stdout, stderr = second.communicate(timeout=60)
        assert second.returncode == 1, (stdout, stderr)
        assert stderr.count("\n") == 1 and "Traceback" not in stderr, stderr
        assert stderr.startswith(f"lfd-track study: {out}: ") and "another" in stderr, stderr
        assert list((tmp_path / "second").iterdir()) == []  # no job ran
        assert _tree(out) == before  # the first study's output is untouched
    first.send_signal(signal.SIGTERM)
    _, stderr = first.communicate(timeout=60)
    assert first.returncode == 143, stderr
    # The lock went with the first study: the folder takes a study again.
    again = studies(study, out, tmp_path / "third", "--workers", workers)
    stdout, stderr = again.communicate(timeout=60)
    assert again.returncode == 0, stderr


def test_killing_the_study_ends_its_workers(tmp_path, studies):
    study, out, folder = write_study(tmp_path), tmp_path / "out", tmp_path / "jobs"
    proc = studies(study, out, folder, "--workers", "2", block="paper/seed0:1,paper/seed1:1")
    workers = {attempt_pid(folder, "paper/seed0"), attempt_pid(folder, "paper/seed1")}
    below = descendants(proc.pid)  # the workers and the processes that start them
    assert workers <= below or not below
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait(timeout=60)  # (its output pipes stay open while any worker holds them)
    left = wait_for_gone(workers | below, timeout=5.0)
    assert not left, f"still running after the study was killed: {sorted(left)}"


def wait_for_gone(pids: set[int], timeout: float) -> set[int]:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        left = {pid for pid in pids if alive(pid)}
        if not left:
            return left
        time.sleep(0.02)
    return {pid for pid in pids if alive(pid)}


def _need_ray() -> None:
    import importlib.util

    from lfd_test_support import unavailable

    if importlib.util.find_spec("ray") is None:
        unavailable("the Ray executor tests need Ray (pip install 'lfd-track[cluster]')")


RAY = ("--executor", "ray", "--workers", "2")


def test_ray_runs_a_killed_worker_s_job_again_then_fails_it_after_the_rest(tmp_path, studies):
    _need_ray()
    study, out, folder = write_study(tmp_path), tmp_path / "out", tmp_path / "jobs"
    proc = studies(study, out, folder, *RAY, block="paper/seed1:2")
    os.kill(attempt_pid(folder, "paper/seed1", 1, timeout=180), signal.SIGKILL)
    os.kill(attempt_pid(folder, "paper/seed1", 2), signal.SIGKILL)  # Ray ran it again
    _, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 1, stderr
    last = stderr.splitlines()[-1]  # (Ray logs a few lines of its own before)
    assert last.startswith("lfd-track study: job paper/seed1 failed: its worker process died")
    assert "Traceback" not in stderr, stderr
    assert finished(out, (0, 1)) == [0]


def test_killing_a_ray_study_ends_its_workers(tmp_path, studies):
    _need_ray()
    study, out, folder = write_study(tmp_path), tmp_path / "out", tmp_path / "jobs"
    proc = studies(study, out, folder, *RAY, block="paper/seed0:1,paper/seed1:1")
    workers = {attempt_pid(folder, "paper/seed0", timeout=180), attempt_pid(folder, "paper/seed1")}
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait(timeout=60)
    # Ray ends the raylet with the study and the task workers with the raylet (its dashboard
    # and runtime-env agents, which run no job, notice about a minute later).
    left = wait_for_gone(workers, timeout=10.0)
    assert not left, f"Ray workers still running after the study was killed: {sorted(left)}"
