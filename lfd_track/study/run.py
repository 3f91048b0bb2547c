"""Run a study's jobs on local processes or Ray tasks, skipping those already finished."""

from __future__ import annotations

import os
import queue as queue_module
import signal
import sys
import threading
import time
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..errors import LfdTrackError, first_line
from ..utils.signals import EXIT_TERMINATED
from ..utils.staging import locked_folder
from .jobs import finished_results, run_job, store_job
from .spec import Job, Study

EXECUTORS = ("local", "ray")

JobDone = Callable[[Job, dict[str, bytes]], None]

LOST_WORKER_TRIES = 2
"""Times a job is started before its worker process dying fails it (a job whose worker dies
runs once more, in a fresh worker: a worker killed from outside is not the job's fault)."""
STOP_S = 5.0
"""Seconds a stopped worker process has to end by itself (its job's clean-up) before it is
killed."""


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
    again: int = 0
    """Jobs started a second time because their worker process died (local executor)."""


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

    A job that raises stops the study (``LfdTrackError`` naming the job). A job whose worker
    process dies (killed, out of memory) runs once more; if it dies again, the other jobs are
    finished first and then ``LfdTrackError`` names it. Either way the finished jobs are kept
    and calling this again runs only the rest. Workers end with the calling process, however
    it ends. This does not lock ``out``: the ``study`` command does (:func:`locked_out`).
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

        again = 0
        if todo:
            if executor == "ray":
                _run_ray(todo, done, workers=workers, address=address)
            else:
                again = _run_local(todo, done, workers=workers)
    return StudyRun(
        total=len(jobs),
        skipped=len(jobs) - len(todo),
        ran=len(todo),
        wall_s=time.perf_counter() - start,
        again=again,
    )


@contextmanager
def locked_out(out: Path) -> Iterator[None]:
    """Hold the output folder ``out`` (which must exist) for one study: ``LfdTrackError`` (one
    line naming it) at once if another process holds it. The lock is the one the benchmark
    takes on its output folder; it goes with the process, however that ends."""
    with locked_folder(
        out, "another lfd-track run is using this folder (one study at a time per --out)"
    ):
        yield


def _failed(job: Job, exc: BaseException) -> LfdTrackError:
    return LfdTrackError(f"job {job.key} failed: {first_line(exc)}")


def _run_local(jobs: Sequence[Job], done: JobDone, *, workers: int) -> int:
    """Run ``jobs`` in this process (``workers`` 1) or in worker processes; return how many
    were started again after their worker process died."""
    if workers == 1:
        for job in jobs:
            try:
                files = run_job(job)
            except Exception as exc:
                raise _failed(job, exc) from exc
            done(job, files)
        return 0
    import multiprocessing

    # Fresh worker processes (no inherited OpenCV/pymunk state), as the benchmark's own pool.
    ctx = multiprocessing.get_context("spawn" if os.name != "posix" else "forkserver")
    return _run_pool(ctx, jobs, done, workers=min(workers, len(jobs)))


def _run_pool(ctx: Any, jobs: Sequence[Job], done: JobDone, *, workers: int) -> int:
    """Run ``jobs`` on up to ``workers`` worker processes (see :class:`_Worker`).

    A job that raises stops the study at once. A job whose worker process dies (killed, out of
    memory) is started again once in a fresh worker; if that one dies too the job fails, after
    the other jobs have run. Leaving, by an error or an interrupt, stops every worker at once
    (the jobs still running are lost, the finished ones are already stored).
    """
    from multiprocessing.connection import wait

    todo = deque(range(len(jobs)))
    starts = [0] * len(jobs)
    busy: list[_Worker] = []
    idle: list[_Worker] = []
    lost: list[str] = []
    again = 0
    try:
        while todo or busy:
            while todo and (idle or len(busy) < workers):
                worker = idle.pop() if idle else _Worker(ctx)
                index = todo.popleft()
                worker.give(index, jobs[index])  # if its process is gone, it is seen below
                starts[index] += 1
                busy.append(worker)
            ready = set(wait([w.results for w in busy] + [w.process.sentinel for w in busy]))
            for worker in [w for w in busy if {w.results, w.process.sentinel} & ready]:
                index, reply = worker.index, worker.reply()
                busy.remove(worker)
                if reply is None:  # the process ended without replying
                    how = worker.stop()
                    if starts[index] < LOST_WORKER_TRIES:
                        todo.append(index)
                        again += 1
                    else:
                        lost.append(
                            f"job {jobs[index].key} failed: its worker process died "
                            f"{_times(starts[index])} ({how})"
                        )
                    continue
                files, problem = reply
                if problem is not None:
                    raise LfdTrackError(f"job {jobs[index].key} failed: {problem}")
                idle.append(worker)
                done(jobs[index], files)
            if not todo:
                _stop_all(idle)
                idle.clear()
    finally:
        _stop_all(busy + idle)
    _raise_lost(lost)
    return again


def _raise_lost(lost: list[str]) -> None:
    """One ``LfdTrackError`` line for the jobs that failed by losing their worker, if any."""
    if lost:
        rest = "the other jobs finished; run the same command to run "
        rest += "it again" if len(lost) == 1 else "them again"
        raise LfdTrackError("; ".join(lost) + f" ({rest})")


def _times(n: int) -> str:
    return {1: "once", 2: "twice"}.get(n, f"{n} times")


class _Worker:
    """One worker process of :func:`_run_pool`, with a pipe for its jobs and one for its
    replies. It ends by itself once the jobs pipe closes: when the study stops it, and when the
    study process ends in any way, ``kill -9`` included (see :func:`_work`)."""

    def __init__(self, ctx: Any) -> None:
        job_reader, self._jobs = ctx.Pipe(duplex=False)
        self.results, reply_writer = ctx.Pipe(duplex=False)
        self.process = ctx.Process(
            target=_work, args=(job_reader, reply_writer), daemon=True, name="lfd-track-job"
        )
        self.process.start()
        job_reader.close()  # the worker's ends: only the worker holds them now
        reply_writer.close()
        self.index = -1
        """The job it runs (its index in the study's list of jobs to run)."""

    def give(self, index: int, job: Job) -> None:
        """Send it a job (if its process is gone, :meth:`reply` will say so)."""
        self.index = index
        try:
            self._jobs.send((index, job))
        except OSError:
            pass

    def reply(self) -> tuple[dict[str, bytes], str | None] | None:
        """Its reply to the job it was given, or None if its process ended without one."""
        try:
            if self.results.poll():
                index, files, problem = self.results.recv()
                return files, problem
        except (EOFError, OSError):
            pass
        return None

    def close(self) -> None:
        """Close its pipes, telling the process to end."""
        self._jobs.close()
        self.results.close()

    def stop(self) -> str:
        """End the process (and wait for it); how it ended, e.g. "killed by SIGKILL"."""
        _stop_all([self])
        return _ended(self.process.exitcode)


def _stop_all(workers: Sequence[_Worker]) -> None:
    """End the workers' processes: each has :data:`STOP_S` to end by itself, then is killed."""
    for worker in workers:
        worker.close()
    deadline = time.monotonic() + STOP_S
    for worker in workers:
        worker.process.join(max(0.0, deadline - time.monotonic()))
        if worker.process.exitcode is None:
            worker.process.kill()
            worker.process.join()


def _ended(code: int | None) -> str:
    if code is not None and code < 0:
        try:
            return f"killed by {signal.Signals(-code).name}"
        except ValueError:
            return f"killed by signal {-code}"
    return f"exit code {code}"


def _work(jobs: Any, results: Any) -> None:
    """A worker process: run the jobs that come through ``jobs``, reply ``(index, files,
    None)`` or ``(index, {}, first line of the error)`` through ``results``.

    A thread receives the jobs. When the jobs pipe closes (the study stopped this worker, or
    the study process ended, however: the pipe closes with the last process holding its far
    end) the worker ends: at once if idle, else its job is stopped as by SIGTERM (its temporary
    folder is removed) and, should that hang, the process exits :data:`STOP_S` later.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the study's: it stops the workers
    signal.signal(signal.SIGTERM, _exit_terminated)
    inbox: queue_module.SimpleQueue[tuple[int, Job] | None] = queue_module.SimpleQueue()
    busy = threading.Event()
    threading.Thread(target=_receive, args=(jobs, inbox, busy), daemon=True).start()
    while (item := inbox.get()) is not None:
        busy.set()
        index, job = item
        reply: tuple[int, dict[str, bytes], str | None]
        try:
            reply = (index, run_job(job), None)
        except Exception as exc:
            reply = (index, {}, first_line(exc))
        results.send(reply)
        busy.clear()


def _receive(jobs: Any, inbox: Any, busy: threading.Event) -> None:
    try:
        while True:
            inbox.put(jobs.recv())
    except (EOFError, OSError):
        pass
    inbox.put(None)
    if busy.is_set():
        os.kill(os.getpid(), signal.SIGTERM)
    time.sleep(STOP_S)
    os._exit(EXIT_TERMINATED)


def _exit_terminated(signum: int, frame: Any) -> None:
    raise SystemExit(EXIT_TERMINATED)


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
    # A task whose worker process dies is run again by Ray, as the local pool does (a job that
    # raises is not: Ray retries exceptions only when asked to).
    lost_worker = (ray.exceptions.WorkerCrashedError, ray.exceptions.OutOfMemoryError)
    pending: dict[Any, Job] = {}
    lost: list[str] = []
    try:
        task = ray.remote(num_cpus=1, max_retries=LOST_WORKER_TRIES - 1)(run_job)
        pending = {task.remote(job): job for job in jobs}
        while pending:
            finished, _ = ray.wait(list(pending), num_returns=1)
            for ref in finished:
                job = pending.pop(ref)
                try:
                    files = ray.get(ref)
                except lost_worker as exc:
                    lost.append(
                        f"job {job.key} failed: its worker process died "
                        f"{_times(LOST_WORKER_TRIES)} ({first_line(exc)})"
                    )
                    continue
                except Exception as exc:
                    cause = getattr(exc, "cause", None) or exc
                    raise _failed(job, cause) from exc
                done(job, files)
        _raise_lost(lost)
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
