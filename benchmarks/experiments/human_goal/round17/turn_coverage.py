"""What the human model's demonstrations say at each turn toward the branch side: round 17's
question is whether its labels teach a learner where a corner's turn ends.

For the chosen configuration of round 17 (the first condition of ``selection_round17.toml``),
each repetition is learned as the study learns it (``learn_repetition``: the same
demonstration), and the demonstration's cases where the map gives a branch side are counted by
the fifth input (the turn toward that side since it was set, 0.5 + turn / 360°) and by the
human's command: toward the side, forward, away from it. Only demonstrations are read (the
training loops ``random:train:36``); no run of the learned policy, no validation or test loop.

    .venv/bin/python benchmarks/experiments/human_goal/round17/turn_coverage.py

writes ``results/turn_coverage.md`` (seed 0, repetitions 0-9: the selection's repetitions).
``--turn-from seen`` counts the turn from the newest frame that saw the branch instead (the
map's ``branch_turn_from``; the human's commands are the same, only the input differs) and writes
``results/turn_coverage_seen.md``.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

import numpy as np

from lfd_track.benchmark.runner import repetition_seeds
from lfd_track.core.commands import Command
from lfd_track.dataset import load_demonstration
from lfd_track.policy.branch_side import UNKNOWN
from lfd_track.study.spec import load_study
from lfd_track.utils.atomic import atomic_write_text

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
from study_repetition import learned_repetition  # noqa: E402

STUDY = HERE / "selection_round17.toml"
SEED, REPETITIONS = 0, 10
#: bins of the fifth input (turn toward the side: 0.5 none, 1.0 half a turn or more)
EDGES = (0.5, 0.5 + 45 / 360, 0.5 + 90 / 360, 0.5 + 135 / 360, 1.0 + 1e-9)
BINS = ("0-45°", "45-90°", "90-135°", "135-180°")


def main() -> None:
    import cv2

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--turn-from", choices=("set", "seen"), default="set")
    turn_from = parser.parse_args().turn_from
    cv2.setNumThreads(1)
    config = load_study(STUDY).conditions[0].config
    memory = dataclasses.replace(config.memory, branch_turn_from=turn_from)
    config = dataclasses.replace(config, memory=memory)
    t0 = time.perf_counter()
    inputs, commands = [], []
    for seed in repetition_seeds(SEED, REPETITIONS):
        with learned_repetition(config, seed) as repetition:
            demo = load_demonstration(repetition.folder / "demonstration.lfdemo")
            inputs.append(np.asarray(demo.policy_inputs("none")))
            commands.append(np.asarray(demo.commands))
    x, a = np.vstack(inputs), np.concatenate(commands)
    side, turn = x[:, 3], x[:, 4]
    known = side != UNKNOWN
    toward = np.where(side > UNKNOWN, Command.LEFT, Command.RIGHT)
    away = np.where(side > UNKNOWN, Command.RIGHT, Command.LEFT)
    md = ["# The human model's labels by the turn toward the branch side", ""]
    md += [f"Round 17's chosen configuration, seed {SEED}, repetitions 0-{REPETITIONS - 1};"]
    md += [
        f"the turn counted from the frame that {'set the side' if turn_from == 'set' else 'last saw the branch'}:"
    ]
    md += [f"{len(a)} demonstration cases, {int(known.sum())} of them with a branch side."]
    md += ["Turned away from the side (input below 0.5): counted in the first bin.", ""]
    md += ["| turn toward the side | cases | toward the side | forward | away |"]
    md += ["|---|---|---|---|---|"]
    for i, name in enumerate(BINS):
        low = -np.inf if i == 0 else EDGES[i]
        sel = known & (turn >= low) & (turn < EDGES[i + 1])
        n = int(sel.sum())
        counts = [
            int((a[sel] == toward[sel]).sum()),
            int((a[sel] == Command.FORWARD).sum()),
            int((a[sel] == away[sel]).sum()),
        ]
        md += [
            f"| {name} | {n} | " + " | ".join(f"{c} ({c / max(n, 1):.0%})" for c in counts) + " |"
        ]
    md += ["", f"{(time.perf_counter() - t0) / 60:.0f} min on one core."]
    out = HERE / "results" / ("turn_coverage.md" if turn_from == "set" else "turn_coverage_seen.md")
    out.parent.mkdir(exist_ok=True)
    atomic_write_text(out, "\n".join(md) + "\n")
    print("\n".join(md))


if __name__ == "__main__":
    main()
