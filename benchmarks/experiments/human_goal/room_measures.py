"""What the rooms rounds' scripts of this folder share (``round24/``, ``round25/``, ``round26/``,
``test_round20/rooms_breakdown.py``, and ``../sharp_corners/rooms30.py``): reading a results
folder's laps, a rank correlation, the robustness study's ground-truth scoring of road values,
and writing a result page.

A script puts this folder on ``sys.path`` (as for ``study_repetition.py``) and imports from here.
"""

from __future__ import annotations

import functools
import importlib.util
import json
import sys
from pathlib import Path
from types import ModuleType

import numpy as np

from lfd_track.benchmark.loops import loop_facts
from lfd_track.utils.atomic import atomic_write_text
from lfd_track.world.loops import turn_bin

HERE = Path(__file__).resolve().parent
#: The sharpest-turn bins of the pages, in order.
BINS = ("<=60", "60-100", "100-135", ">135")
#: The robustness study's script whose ground truth (``felt_share``, ``felt_level``) and
#: within-session score (``separation``) the rounds reuse.
FELT_LEVELS_SCRIPT = HERE.parent / "robustness" / "felt_levels.py"


def job_loop_outcomes(job: dict) -> dict[tuple, dict]:
    """Each loop lap's outcome record of one read ``results.json`` (a study job's or a rules
    run's), keyed by (repetition, loop, direction, trial): the training track and the testing
    track left out."""
    return {
        (o["repetition"], o["track"], o["direction"], o.get("trial", 0)): o
        for o in job["outcomes"]
        if o["track"] not in ("training", "testing")
    }


def loop_outcomes(folder: Path) -> dict[tuple, dict]:
    """:func:`job_loop_outcomes` of every ``results.json`` under ``folder``, keyed alike."""
    out: dict[tuple, dict] = {}
    for path in sorted(folder.rglob("results.json")):
        out.update(job_loop_outcomes(json.loads(path.read_text(encoding="utf-8"))))
    return out


def seed_jobs(folder: Path, seeds: tuple[int, ...]) -> dict[int, dict]:
    """Each seed's ``results.json`` under ``folder`` (``seed<N>/``, which must have run), read."""
    jobs = {}
    for seed in seeds:
        path = folder / f"seed{seed}" / "results.json"
        if not path.is_file():
            raise SystemExit(f"{path.parent}: not run yet (README.md)")
        jobs[seed] = json.loads(path.read_text(encoding="utf-8"))
    return jobs


def seeds_loop_outcomes(jobs: dict[int, dict]) -> dict[tuple, dict]:
    """:func:`job_loop_outcomes` of each seed's job (:func:`seed_jobs`), keyed by (seed,
    repetition, loop, direction, trial)."""
    return {
        (seed, *key): o for seed, job in jobs.items() for key, o in job_loop_outcomes(job).items()
    }


def loop_bins(outcomes: dict[tuple, dict]) -> dict[str, str]:
    """Each loop's sharpest-turn bin, for outcomes keyed as :func:`seeds_loop_outcomes`."""
    return {track: turn_bin(loop_facts(track)[0]) for track in {key[2] for key in outcomes}}


def laps_by_bin(outcomes: dict[tuple, dict], bins: dict[str, str]) -> dict[str, list[int]]:
    """[lapped, driven] per sharpest-turn bin (:data:`BINS`) of ``outcomes`` (keyed as
    :func:`seeds_loop_outcomes`), each loop's bin from ``bins`` (:func:`loop_bins`)."""
    out = {b: [0, 0] for b in BINS}
    for key, o in outcomes.items():
        out[bins[key[2]]][0] += bool(o["success"])
        out[bins[key[2]]][1] += 1
    return out


def loop_laps(folder: Path) -> dict[tuple, bool]:
    """Each loop lap's success under ``folder``, keyed as :func:`loop_outcomes`."""
    return {key: o["success"] for key, o in loop_outcomes(folder).items()}


def repetition_laps(folder: Path) -> dict[int, tuple[int, int]]:
    """Per repetition under ``folder``: (loop laps lapped, training-track runs lapped)."""
    loops: dict[int, int] = {}
    training: dict[int, int] = {}
    for path in sorted(folder.rglob("results.json")):
        for o in json.loads(path.read_text(encoding="utf-8"))["outcomes"]:
            counts = training if o["track"] == "training" else loops
            if o["track"] != "testing":
                counts[o["repetition"]] = counts.get(o["repetition"], 0) + int(o["success"])
    return {
        r: (loops.get(r, 0), training.get(r, 0)) for r in sorted(loops.keys() | training.keys())
    }


def spearman(a: np.ndarray, b: np.ndarray) -> float:
    """Spearman's rank correlation of ``a`` and ``b`` (ties share their mean rank)."""
    return float(np.corrcoef(_ranks(np.asarray(a)), _ranks(np.asarray(b)))[0, 1])


def _ranks(values: np.ndarray) -> np.ndarray:
    order = np.argsort(values, kind="stable")
    ranks = np.empty(len(values))
    ranks[order] = np.arange(len(values))
    for v in np.unique(values):  # ties share their mean rank
        ranks[values == v] = ranks[values == v].mean()
    return ranks


@functools.cache
def robustness_felt_levels() -> ModuleType:
    """``../robustness/felt_levels.py`` loaded as a module (it is a script, not a package)."""
    spec = importlib.util.spec_from_file_location("robustness_felt_levels", FELT_LEVELS_SCRIPT)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def write_page(path: Path, lines: list[str]) -> None:
    """Write a result page (markdown lines) atomically, creating its folder, and print it."""
    path.parent.mkdir(parents=True, exist_ok=True)
    text = "\n".join(lines) + "\n"
    atomic_write_text(path, text)
    print(text, end="")
