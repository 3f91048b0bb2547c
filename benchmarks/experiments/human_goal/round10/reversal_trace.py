"""Where round 9's winner turns round on the paper's training track: its inputs, step by step.

Round 9's winner (``../test_round9/``) turns round on the training track in 5 of the 60 runs of
its test study's seed 2, 5 of them in repetitions 8 and 9, and its branch side held at none
removes 4 of the 5 (``../round09/results/branch_ablation_*_seed2.md``). This script learns those
two repetitions as the study does (``learn_repetition``), drives their training-track runs
(``run_trials``, the study's world seeds; the training track only, no test loop or testing
track), and logs the four map inputs (bearing, amount, distance of the fresh felt, branch side)
and the command at every step, with the fresh felt's bearing before the input clips it to 30°
(``FreshFeltMemory.bearing_deg``); for each reversed run it writes the commands and the last 45
steps to ``results/reversal_trace.md``.

    .venv/bin/python benchmarks/experiments/human_goal/round10/reversal_trace.py
"""

from __future__ import annotations

import dataclasses
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from lfd_track.benchmark.runner import repetition_seeds
from lfd_track.study.spec import load_study
from lfd_track.utils.atomic import atomic_write_text

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "round07"))
sys.path.insert(0, str(HERE.parent))
from branch_ablation import Wrapped  # noqa: E402
from study_repetition import learned_repetition, training_runs  # noqa: E402

STUDY = HERE.parent / "test_round9" / "test_round9.toml"
SEED, REPETITIONS = 2, (8, 9)
LETTERS = "FLR"


@dataclasses.dataclass
class Logged(Wrapped):
    """The controller's own network, inputs untouched, each step's inputs and command logged."""

    log: list[tuple[tuple[float, ...], float | None, int]] = dataclasses.field(default_factory=list)
    seen: Any = None

    def perception(self) -> Any:
        self.seen = super().perception()
        return self.seen

    def commander(self) -> Any:
        commander = super().commander()
        propose = commander.propose

        def logged(moment: Any) -> Any:
            command = propose(moment)
            inputs = tuple(float(x) for x in moment.policy_inputs)
            self.log.append((inputs, self.seen._memory.bearing_deg, int(command)))
            return command

        commander.propose = logged  # type: ignore[method-assign]
        return commander


def main() -> None:
    import cv2

    cv2.setNumThreads(1)
    study = load_study(STUDY)
    config = dataclasses.replace(study.conditions[0].config, seed=SEED)
    t0 = time.perf_counter()
    md = ["# Where round 9's winner turns round on the training track", ""]
    md += [f"Seed {SEED}, repetitions {REPETITIONS}; inputs (bearing, amount, distance, side)."]
    for index, seed in enumerate(repetition_seeds(SEED, max(REPETITIONS) + 1)):
        if index not in REPETITIONS:
            continue
        with learned_repetition(config, seed) as repetition:
            pass
        driver = Logged(repetition.learned.controller, repetition.preset, hold=False)
        outcomes = training_runs(driver, repetition, config, index)
        md += ["", f"## Repetition {index}", ""]
        md += [", ".join(f"{o.direction} {o.failure or 'lapped'} ({o.steps})" for o in outcomes)]
        start = 0
        for number, outcome in enumerate(outcomes):
            steps = driver.log[start : start + outcome.steps]
            start += outcome.steps
            if outcome.failure != "reversed":
                continue
            md += ["", f"Run {number} ({outcome.direction}), reversed:", ""]
            md += ["    " + "".join(LETTERS[c] for _, _, c in steps), ""]
            md += ["| step | bearing | amount | distance | side | bearing [deg] | command |"]
            md += ["|---|---|---|---|---|---|---|"]
            for i in range(max(0, len(steps) - 45), len(steps)):
                x, raw, c = steps[i]
                deg = "blank" if raw is None else f"{raw:+.0f}"
                values = " | ".join(f"{v:.2f}" for v in np.round(x, 2))
                md += [f"| {i} | {values} | {deg} | {LETTERS[c]} |"]
    md += ["", f"{(time.perf_counter() - t0) / 60:.0f} min on one core."]
    (HERE / "results").mkdir(exist_ok=True)
    atomic_write_text(HERE / "results" / "reversal_trace.md", "\n".join(md) + "\n")


if __name__ == "__main__":
    main()
