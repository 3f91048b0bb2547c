"""How often the human's commands agree with the fresh-felt rule on the same map inputs.

The limits experiment's rule on the ``fresh_felt`` memory laps loops the learners cannot; a
learner given that memory can only take the rule up if the human's commands follow it. For the
first demonstration of each of the paper protocol's seeds 0-2 (the paper pipeline's repetition 0,
recorded with the ``fresh_felt`` memory of ``selection.toml``), this replays the recorded map
inputs through :class:`lfd_track.teaching.handwritten.FreshFeltRule` (the limits experiment's
chosen ``turn_deg``) and counts, over the driving cases (turn-arounds left out), how often its
command is the human's, beside the share of the commonest command (always forward).

    .venv/bin/python benchmarks/experiments/goal/round01/label_agreement.py [--out DIR]

Writes ``label_agreement.json`` and ``.md`` into ``results/`` beside this file (round 1's
folder), or into ``--out`` (to check a rerun against the committed files without replacing them).
"""

from __future__ import annotations

import argparse
import json
import tempfile
from pathlib import Path

import numpy as np

from lfd_track.benchmark.runner import repetition_seeds, repetition_streams
from lfd_track.dataset import load_demonstration
from lfd_track.demo.demonstrator import run_demonstration
from lfd_track.policy.memory import FreshFeltConfig
from lfd_track.teaching.handwritten import FreshFeltRule, FreshFeltRuleConfig

HERE = Path(__file__).resolve().parent
# Round 1's map: every option off, the limits rule's radius and reach.
MEMORY = FreshFeltConfig.plain(path_radius_m=0.35, reach_m=0.6)
TURN_DEG = 20.0  # the limits experiment's chosen rule (limits/results/tune_fresh.json)
NAMES = ("forward", "left", "right")


def agreement(seed: int) -> dict:
    """Agreement of the rule with the human on one demonstration of benchmark ``seed``."""
    demo_seed, _, _ = repetition_streams(repetition_seeds(seed, 10)[0])
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "demonstration.lfdemo"
        run_demonstration(path, seed=demo_seed, fsync=False, memory=MEMORY)
        demo = load_demonstration(path)
    rule = FreshFeltRule(FreshFeltRuleConfig(turn_deg=TURN_DEG, memory=MEMORY))
    # The rule's fallback bit (the side the fresh felt last lay on) follows every case in order.
    proposed = np.array([int(rule.act(m)) for m in np.asarray(demo.memory)])
    human = np.asarray(demo.commands, dtype=int)
    driving = np.asarray(demo.phases) == "drive"
    confusion = np.zeros((3, 3), dtype=int)  # rows: human, columns: rule
    np.add.at(confusion, (human[driving], proposed[driving]), 1)
    n = int(driving.sum())
    return {
        "seed": seed,
        "demonstration_seed": int(demo_seed),
        "driving_cases": n,
        "agreement": float((human[driving] == proposed[driving]).mean()),
        "always_forward": float((human[driving] == 0).mean()),
        "confusion_human_rows_rule_columns": confusion.tolist(),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--out", type=Path, default=HERE / "results", help="folder for the .json and .md"
    )
    out = parser.parse_args(argv).out
    rows = [agreement(seed) for seed in (0, 1, 2)]
    out.mkdir(parents=True, exist_ok=True)
    payload = {"memory": MEMORY.to_dict(), "turn_deg": TURN_DEG, "seeds": rows}
    (out / "label_agreement.json").write_text(json.dumps(payload, indent=1) + "\n")
    lines = [
        "Agreement of the fresh-felt rule with the human's commands on the driving cases of one "
        "demonstration per seed (turn-arounds left out).",
        "",
        "| seed | driving cases | rule = human | always forward = human | human F/L/R → rule F/L/R |",
        "|---|---|---|---|---|",
    ]
    for r in rows:
        conf = "; ".join(
            f"{NAMES[i][0].upper()}: " + "/".join(str(v) for v in row)
            for i, row in enumerate(r["confusion_human_rows_rule_columns"])
        )
        lines.append(
            f"| {r['seed']} | {r['driving_cases']} | {100 * r['agreement']:.0f} % | "
            f"{100 * r['always_forward']:.0f} % | {conf} |"
        )
    (out / "label_agreement.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
