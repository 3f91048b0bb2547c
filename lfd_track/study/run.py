"""Run a study's jobs on local processes or Ray tasks, skipping those already finished."""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..errors import LfdTrackError
from .jobs import finished_results, run_job, store_job
from .spec import Job, Study

EXECUTORS = ("local", "ray")

JobDone = Callable[[Job, dict[str, bytes]], None]


@dataclass(frozen=True)
class StudyRun:
    """What one invocation of :func:`run_study` did."""

    total: int
    """Jobs in the study."""
    skipped: int
    """Jobs finished by an earlier invocation (not rerun)."""
    ran: int
    """Jobs run now."""
    wall_s: float
    """Seconds this invocation spent running jobs."""


def run_study(
    study: Study,
    out: Path,
    *,
    executor: str = "local",
    workers: int = 1,
    address: str | None = None,
    progress: bool = False,
) -> StudyRun:
    """Run every unfinished job of ``study``, writing each job's files into ``out`` as it ends.

    ``executor`` is ``"local"`` (``workers`` processes; 1 runs in this process) or ``"ray"``
    (Ray tasks of one CPU each, on the cluster at ``address`` or a local Ray with ``workers``
    CPUs). ``progress`` shows jobs done / total with an ETA (tqdm).
    """
    if executor not in EXECUTORS:
        raise LfdTrackError(f"unknown executor '{executor}' (choose {' or '.join(EXECUTORS)})")
    if workers < 1:
        raise LfdTrackError(f"workers must be at least 1, got {workers}")
    jobs = study.jobs()
    todo = [job for job in jobs if finished_results(out, job) is None]
    from tqdm import tqdm

    start = time.perf_counter()
    with tqdm(
        total=len(jobs),
        initial=len(jobs) - len(todo),
        desc=f"study {study.name}",
        unit="job",
        disable=not progress,
        file=sys.stderr,
        dynamic_ncols=True,
    ) as bar:

        def done(job: Job, files: dict[str, bytes]) -> None:
            store_job(out, job, files)
            bar.set_postfix_str(f"last: {job.key}")
            bar.update(1)

        if todo:
            if executor == "ray":
                _run_ray(todo, done, workers=workers, address=address)
            else:
                _run_local(todo, done, workers=workers)
    return StudyRun(
        total=len(jobs),
        skipped=len(jobs) - len(todo),
        ran=len(todo),
        wall_s=time.perf_counter() - start,
    )


def _first_line(exc: BaseException) -> str:
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__


def _failed(job: Job, exc: BaseException) -> LfdTrackError:
    return LfdTrackError(f"job {job.key} failed: {_first_line(exc)}")


def _run_local(jobs: Sequence[Job], done: JobDone, *, workers: int) -> None:
    if workers == 1:
        for job in jobs:
            try:
                files = run_job(job)
            except Exception as exc:
                raise _failed(job, exc) from exc
            done(job, files)
        return
    import multiprocessing

    # Fresh worker processes (no inherited OpenCV/pymunk state), as the benchmark's own pool.
    # Leaving the with-block terminates the workers, so an interrupt or a failed job does not
    # wait for the jobs still running (they are lost, the finished ones are already stored).
    ctx = multiprocessing.get_context("spawn" if os.name != "posix" else "forkserver")
    with ctx.Pool(processes=min(workers, len(jobs))) as pool:
        for index, files, problem in pool.imap_unordered(_run_indexed, list(enumerate(jobs))):
            if problem is not None:
                raise LfdTrackError(f"job {jobs[index].key} failed: {problem}")
            done(jobs[index], files)


def _run_indexed(item: tuple[int, Job]) -> tuple[int, dict[str, bytes], str | None]:
    """Pool worker: ``(index, files, None)``, or ``(index, {}, first line of the error)``."""
    index, job = item
    try:
        return index, run_job(job), None
    except Exception as exc:
        return index, {}, _first_line(exc)


def _run_ray(jobs: Sequence[Job], done: JobDone, *, workers: int, address: str | None) -> None:
    try:
        import ray
    except ImportError:
        raise LfdTrackError("--executor ray needs Ray: pip install 'lfd-track[cluster]'") from None
    # Ray would otherwise report usage statistics over the network.
    os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
    started_here = not ray.is_initialized()
    if started_here:
        options: dict[str, Any] = {"log_to_driver": False, "include_dashboard": False}
        if address:
            ray.init(address=address, **options)
        else:
            # Loopback only; a small object store, as jobs return only a few small files.
            ray.init(
                num_cpus=workers,
                _node_ip_address="127.0.0.1",
                object_store_memory=256 * 1024**2,
                **options,
            )
    pending: dict[Any, Job] = {}
    try:
        task = ray.remote(num_cpus=1, max_retries=0)(run_job)
        pending = {task.remote(job): job for job in jobs}
        while pending:
            finished, _ = ray.wait(list(pending), num_returns=1)
            for ref in finished:
                job = pending.pop(ref)
                try:
                    files = ray.get(ref)
                except Exception as exc:
                    cause = getattr(exc, "cause", None) or exc
                    raise _failed(job, cause) from exc
                done(job, files)
    except BaseException:
        for ref in pending:
            ray.cancel(ref, force=True)
        raise
    finally:
        if started_here:
            ray.shutdown()


def load_finished(study: Study, out: Path) -> list[tuple[Job, dict[str, Any]]]:
    """Every job of ``study`` with its stored results; raises if any job is unfinished."""
    pairs = []
    for job in study.jobs():
        results = finished_results(out, job)
        if results is None:
            raise LfdTrackError(f"job {job.key} has not finished")
        pairs.append((job, results))
    return pairs
