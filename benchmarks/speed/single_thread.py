"""One-thread pinning and machine facts shared by the speed benchmarks.

Every ratio in ``benchmarks/speed/`` is measured with both sides on one core: OpenCV limited to one
thread (``cv2.setNumThreads(1)``) and the BLAS behind numpy limited to one thread
(threadpoolctl). On a shared 2-core machine a second thread mostly measures who else is busy.
"""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path
from typing import Any

import cv2
from threadpoolctl import threadpool_limits

from lfd_track.utils.atomic import atomic_write_text
from lfd_track.utils.provenance import environment

REPO = Path(__file__).resolve().parents[2]

# Child processes (gymnasium's async vector env, the paper protocol's workers) read these when
# their BLAS starts.
for _name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_name] = "1"


def pin_one_thread() -> None:
    """Limit OpenCV and numpy's BLAS in this process to one thread each."""
    cv2.setNumThreads(1)
    threadpool_limits(limits=1)


def pin_core(core: int | None) -> None:
    """Pin this process to CPU ``core`` (``os.sched_setaffinity``; None: leave it free). Raises
    ``ValueError`` naming the cores it may use when ``core`` is not one of them."""
    if core is None:
        return
    allowed = sorted(os.sched_getaffinity(0))
    if core not in allowed:
        raise ValueError(f"core {core} is not one of this process's cores {allowed}")
    os.sched_setaffinity(0, {core})


def machine() -> dict[str, Any]:
    """Versions, the BLAS kernel (lfd_track.utils.provenance), the thread settings in force, and the
    machine's processor count."""
    return {**environment(), "opencv_threads": cv2.getNumThreads()}


def load_average() -> list[float]:
    """1, 5 and 15 minute load averages (runnable processes on the machine's 2 cores)."""
    return [round(x, 2) for x in os.getloadavg()]


def source_state(root: Path = REPO) -> dict[str, object]:
    """Commit of the checkout at ``root`` (this one by default) and its uncommitted package
    files (they are what was measured)."""

    def git(*args: str) -> str:
        try:
            proc = subprocess.run(
                ["git", *args], cwd=root, capture_output=True, text=True, timeout=10, check=True
            )
        except (OSError, subprocess.SubprocessError):
            return ""
        return proc.stdout

    # Porcelain lines are "XY path"; the status columns may start with a space.
    dirty = git("status", "--porcelain", "--", "lfd_track", "envs", "tracks")
    return {
        "commit": git("rev-parse", "HEAD").strip() or None,
        "uncommitted": [line[3:] for line in dirty.splitlines()],
    }


def write_results(path: Path, result: dict[str, Any], load_before: list[float]) -> None:
    """Write a benchmark's ``result`` as JSON to ``path`` (atomically), and print the load
    average before and now and where it went."""
    atomic_write_text(path, json.dumps(result, indent=2) + "\n")
    print(f"load average (1, 5, 15 min): before {load_before}, after {load_average()}")
    print(f"wrote {path}")


def run_facts(load_before: list[float]) -> dict[str, Any]:
    """What every results file records of the run: the load average before and after, the
    machine and the source measured."""
    return {
        "load_average_before": load_before,
        "load_average_after": load_average(),
        "machine": machine(),
        "source": source_state(),
    }
