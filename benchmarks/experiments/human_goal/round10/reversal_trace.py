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

``--study FILE --seed N --repetitions A,B --out FILE`` traces another frozen configuration's
training-track runs the same way (the first condition of FILE); with the map's fifth input
(``branch_turn``) its column is logged too. Round 17's winner:
``--study benchmarks/experiments/human_goal/test_round17/test_round17.toml --seed 2
--repetitions 8,9 --out benchmarks/experiments/human_goal/round17/results/reversal_trace_seed2.md``
(and ``--seed 1 --repetitions 1``, ``reversal_trace_seed1.md``).
"""

from __future__ import annotations

import argparse
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

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--study", type=Path, default=STUDY)
    parser.add_argument("--seed", type=int, default=SEED)
    parser.add_argument(
        "--repetitions", type=lambda t: tuple(int(x) for x in t.split(",")), default=REPETITIONS
    )
    parser.add_argument("--out", type=Path, default=HERE / "results" / "reversal_trace.md")
    args = parser.parse_args()
    cv2.setNumThreads(1)
    study = load_study(args.study)
    condition = study.conditions[0]
    config = dataclasses.replace(condition.config, seed=args.seed)
    names = ["bearing", "amount", "distance", "side", "turn"][: config.memory.n_inputs]
    t0 = time.perf_counter()
    if args.study == STUDY:
        md = ["# Where round 9's winner turns round on the training track", ""]
    else:
        md = [f"# Where `{condition.name}` turns round on the training track", ""]
        md += [f"The first condition of `{args.study.name}`.", ""]
    md += [f"Seed {args.seed}, repetitions {args.repetitions}; inputs ({', '.join(names)})."]
    for index, seed in enumerate(repetition_seeds(args.seed, max(args.repetitions) + 1)):
        if index not in args.repetitions:
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
            md += [f"| step | {' | '.join(names)} | bearing [deg] | command |"]
            md += ["|---" * (len(names) + 3) + "|"]
            for i in range(max(0, len(steps) - 45), len(steps)):
                x, raw, c = steps[i]
                deg = "blank" if raw is None else f"{raw:+.0f}"
                values = " | ".join(f"{v:.2f}" for v in np.round(x, 2))
                md += [f"| {i} | {values} | {deg} | {LETTERS[c]} |"]
    md += ["", f"{(time.perf_counter() - t0) / 60:.0f} min on one core."]
    args.out.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(args.out, "\n".join(md) + "\n")


if __name__ == "__main__":
    main()
