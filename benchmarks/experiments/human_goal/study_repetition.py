"""One repetition of a study's condition, learned as the study's job learns it, for the scripts of
this folder that drive a learned controller outside the study (``where_they_part.py``,
``round07/branch_ablation.py``, ``round10/reversal_trace.py``): the repetition's streams, its
world (its room with ``room = "per_repetition"``), the map's calibration there, and
``learn_repetition`` into a temporary folder kept open while the caller reads it; and its runs
on the training track alone, as the study drives them (:func:`training_runs`)."""

from __future__ import annotations

import contextlib
import dataclasses
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from lfd_track.benchmark.runner import (
    learn_repetition,
    repetition_preset,
    repetition_streams,
    run_trials,
)
from lfd_track.methods.common import calibration_for


@dataclasses.dataclass(frozen=True)
class StudyRepetition:
    """What ``learn_repetition`` returned, the world it was taught in, the seed of its trials,
    and the folder its demonstration and controller were written to (gone on leaving)."""

    learned: Any
    preset: Any
    trial_seed: int
    folder: Path


@contextlib.contextmanager
def learned_repetition(config: Any, seed: int) -> Iterator[StudyRepetition]:
    """Learn the repetition of ``config`` (a study condition's ``BenchmarkConfig``) whose
    repetition seed is ``seed``; its folder lasts as long as the ``with`` block."""
    demo_seed, ga_seed, trial_seed = repetition_streams(seed)
    preset = repetition_preset(config, seed)
    calibration = calibration_for(config.memory, preset, seed)
    with tempfile.TemporaryDirectory() as tmp:
        learned = learn_repetition(
            config,
            Path(tmp),
            demo_seed=demo_seed,
            ga_seed=ga_seed,
            preset=preset,
            calibration=calibration,
        )
        yield StudyRepetition(learned, preset, trial_seed, Path(tmp))


def training_runs(driver: Any, repetition: StudyRepetition, config: Any, index: int) -> list[Any]:
    """The study's training-track runs of repetition ``index`` (its world seeds and trials per
    direction; no test loop or testing track), driven by ``driver`` (the learned controller, or
    a wrapper of it)."""
    return run_trials(
        driver,
        trial_seed=repetition.trial_seed,
        test_tracks=(),
        trials_per_direction=config.trials_per_direction,
        preset=repetition.preset,
        repetition=index,
        tracks={"training"},
    )
