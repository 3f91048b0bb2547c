"""With $LFD_TEST_STUDY_DIR set, importing this module makes every study job scripted
(:func:`scripted_job`), in this process and in the local pool's workers (their fork server
preloads it, see :data:`SCRIPTED_MAIN`); without it, importing changes nothing.

A scripted job takes milliseconds, tells the test which process runs which attempt of which
job, and can be made to wait to be killed, so a test can kill a worker (or the study) in the
middle of a job.
"""

from __future__ import annotations

import json
import os
import time
from pathlib import Path

from study_helpers import job_results

import lfd_track.study.run as run_module

SCRIPT_DIR = "LFD_TEST_STUDY_DIR"
"""Environment variable naming the folder through which :func:`scripted_job` reports."""
BLOCK = "LFD_TEST_STUDY_BLOCK"
"""Environment variable ``KEY:N[,KEY:N...]``: the first N attempts of job KEY wait to be
killed."""


def attempt_file(folder: Path, key: str, attempt: int) -> Path:
    """Where :func:`scripted_job` writes the pid of the process running ``key``'s attempt."""
    return folder / f"{key.replace('/', '-')}.{attempt}.pid"


def scripted_job(job) -> dict:
    """Record this process's pid as the next attempt of ``job`` in $LFD_TEST_STUDY_DIR, then
    return :func:`job_results` at once or, for an attempt $LFD_TEST_STUDY_BLOCK names, wait (a
    minute at most) to be killed."""
    folder = Path(os.environ[SCRIPT_DIR])
    attempt = 1
    while attempt_file(folder, job.key, attempt).exists():
        attempt += 1
    partial = folder / f".{os.getpid()}.tmp"
    partial.write_text(str(os.getpid()))
    os.replace(partial, attempt_file(folder, job.key, attempt))
    blocked = dict(item.split(":") for item in os.environ.get(BLOCK, "").split(",") if item)
    if attempt <= int(blocked.get(job.key, 0)):
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:  # stands in for a long job
            time.sleep(0.05)
        raise RuntimeError(f"job {job.key} was not killed")
    results = json.dumps(job_results(job)).encode()
    return {"report.md": b"report\n", "results.json": results}


if SCRIPT_DIR in os.environ:
    run_module.run_job = scripted_job

SCRIPTED_MAIN = """
import multiprocessing, sys
multiprocessing.set_forkserver_preload(["scripted_jobs"])
import scripted_jobs
from lfd_track.cli import main
sys.exit(main(sys.argv[1:]))
"""
"""``python -c SCRIPTED_MAIN ARGS...`` is ``lfd-track ARGS`` with every job scripted (the
tests' folder and the repository must be on PYTHONPATH)."""
