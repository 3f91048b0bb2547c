"""One study job: the paper protocol for one (condition, seed), and where its results live.

A job runs in a temporary folder on whatever machine executes it (a local process or a Ray
worker) and returns its output files as bytes, so the machine that runs the study writes every
file itself and a cluster needs no shared file system. A job is finished exactly when
``OUT/<condition>/seed<k>/results.json`` exists: that file is written atomically, after the
job's report, so an interrupted study loses at most the jobs that were running.
"""

from __future__ import annotations

import json
import os
import tempfile
import time
from pathlib import Path
from typing import Any

from ..benchmark.runner import config_dict, run_benchmark
from ..benchmark.schema import migrate_results
from ..benchmark.tables import results_json_text
from ..errors import FileFormatError, first_line
from ..utils.atomic import atomic_write_bytes
from ..utils.files import read_regular_text
from .spec import Job

RESULTS_FILE = "results.json"
MAX_RESULTS_BYTES = 1 << 28
"""Largest results.json read back (a 10-repetition job writes about 100 kB)."""
JOB_FILES = ("report.md", RESULTS_FILE)
"""Files kept from each job's benchmark outputs, in the order they are written (results last)."""


def run_job(job: Job) -> dict[str, bytes]:
    """Run one job's benchmark (one process) and return ``{file name: contents}``.

    The outputs are exactly what ``lfd-track benchmark`` writes for the same settings; the
    demonstrations, controllers and pictures are not kept.
    """
    from ..benchmark.report import write_benchmark_outputs

    with tempfile.TemporaryDirectory(prefix="lfd-track-job-") as tmp:
        folder = Path(tmp)
        start = time.perf_counter()
        reps = run_benchmark(job.config, folder / "repetitions", workers=1)
        wall_s = time.perf_counter() - start
        write_benchmark_outputs(folder, job.config, reps, wall_s=wall_s, workers=1)
        return {name: (folder / name).read_bytes() for name in JOB_FILES}


def job_folder(out: Path, job: Job) -> Path:
    """Where the job's files go: ``out/<condition>/seed<k>``."""
    return out / job.condition / f"seed{job.seed}"


def store_job(out: Path, job: Job, files: dict[str, bytes]) -> None:
    """Write a finished job's files, ``results.json`` last (each one atomically)."""
    folder = job_folder(out, job)
    for name in JOB_FILES:
        atomic_write_bytes(folder / name, files[name])


def expected_config(job: Job) -> dict[str, Any]:
    """The job's settings as its results.json stores them."""
    return json.loads(results_json_text({"config": config_dict(job.config)}))["config"]


def same_settings(stored: Any, expected: dict[str, Any]) -> bool:
    """Whether a stored results.json ``config`` holds the settings ``expected``: equal, with a
    preset path read in its normal form (``round/planned/../presets/a.toml`` names the file
    ``round/presets/a.toml`` names, so a study file moved out of ``planned/`` keeps its results)."""

    def normal(config: Any) -> Any:
        preset = config.get("preset") if isinstance(config, dict) else None
        if isinstance(preset, str) and "/" in preset:
            return {**config, "preset": os.path.normpath(preset)}
        return config

    return bool(normal(stored) == normal(expected))


def finished_results(out: Path, job: Job) -> dict[str, Any] | None:
    """The job's results if it finished earlier, else None.

    Raises ``FileFormatError`` (one line naming the results.json) if the stored results were
    produced with other settings than the study now asks for (rerunning would mix two studies
    in one folder), or are damaged: unreadable, not a regular file, larger than
    :data:`MAX_RESULTS_BYTES`, not JSON, nested too deeply, missing (or holding wrongly typed)
    any field the summary reads, or holding other trials than the job's repetitions x trials
    per direction of each direction (:func:`~lfd_track.study.summary.check_job_results`).

    A damaged file is an error, never a reason to rerun: the study stops before running any job
    and the file is left as it is; the message tells the user to delete that job's folder, so
    the next run redoes that job alone.
    """
    path = job_folder(out, job) / RESULTS_FILE
    if not (path.exists() or path.is_symlink()):
        return None
    rerun = "delete this job's folder to rerun it"
    try:
        results = json.loads(read_regular_text(path, MAX_RESULTS_BYTES, "results"))
    except RecursionError:
        raise FileFormatError(
            path, f"unreadable results (JSON nested too deeply); {rerun}"
        ) from None
    except MemoryError:
        raise FileFormatError(path, f"unreadable results (too large for memory); {rerun}") from None
    except ValueError as exc:  # not JSON, or an integer of thousands of digits
        raise FileFormatError(path, f"unreadable results ({first_line(exc)}); {rerun}") from None
    if isinstance(results, dict):
        results = migrate_results(results, path)  # an older schema is read as the current one
    if not isinstance(results, dict) or not same_settings(
        results.get("config"), expected_config(job)
    ):
        raise FileFormatError(
            path,
            f"was run with other settings than condition '{job.condition}' now has "
            "(use another --out folder, or delete this job's folder to rerun it)",
        )
    from .summary import check_job_results

    try:
        check_job_results(
            results,
            job.config.repetitions,
            job.config.trials_per_direction,
            job.config.test_tracks,
            job.config.random_loops,
        )
    except ValueError as exc:
        raise FileFormatError(path, f"damaged results: {first_line(exc)}; {rerun}") from None
    return results
