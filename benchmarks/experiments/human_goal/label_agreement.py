"""Which of the policy's possible inputs explain the centreline human's commands?

The chosen configuration (``../goal/distilled.toml``) reads only the ``fresh_felt`` map and was
taught by a rule on that very map. Taught by the paper's human model instead (pure pursuit on the
true centreline 0.35 m ahead, dead-band 15°, 10 % reaction delays, 3 % lapses), a learner can take
up only what of the human's commands its inputs explain. For the first demonstration of
benchmark seeds 0-2 (as a study records it, the shipped ``fresh_felt`` map), this counts over the
driving cases (turn-arounds left out):

* the cases with no fresh felt on the map (``blank``) and what the human commanded there;
* how often a threshold rule on the map's bearing input gives the human's command (the
  threshold that agrees best, 5-40° in 1° steps: an upper bound for a rule on that input alone);
* the same for the ``near_felt`` position (where the felt lies across the picture's two nearest
  rows, ``lfd_track/policy/features.py``; thresholds 0.01-0.40 from the middle);
* the share of forward commands (what "always forward" agrees on).

Three protocols: the paper's training track as the studies demonstrate it, the same with the map
started afresh at every leg (``clear_memory_per_leg``), and a lap each way of the train-split loop
``random:train:36`` (6.5 m; turns of -80, 144, 65, 54, 135 and 42°) with the map started afresh
at each lap.

    .venv/bin/python benchmarks/experiments/human_goal/label_agreement.py [--out DIR]

Writes ``label_agreement.json`` and ``.md`` into ``results/`` beside this file (or ``--out``).
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
from lfd_track.policy.features import near_felt_features
from lfd_track.policy.memory import FreshFeltConfig, fresh_bearing_rad
from lfd_track.teaching.scripted import HumanConfig
from lfd_track.utils.atomic import atomic_write_text

HERE = Path(__file__).resolve().parent
MEMORY = FreshFeltConfig()  # the shipped map: the chosen configuration's
PROTOCOLS = {
    "training": ("training", HumanConfig()),
    "training, map afresh per leg": ("training", HumanConfig(clear_memory_per_leg=True)),
    "random:train:36 a lap each way, map afresh per lap": (
        "random:train:36",
        HumanConfig(legs=2, clear_memory_per_leg=True),
    ),
}
NAMES = ("forward", "left", "right")


def _best(signal: np.ndarray, human: np.ndarray, thresholds: np.ndarray) -> tuple[float, float]:
    """(agreement, threshold) of the best rule "left above t, right below -t, else forward"."""
    best = (-1.0, 0.0)
    for t in thresholds:
        rule = np.where(signal > t, 1, np.where(signal < -t, 2, 0))
        best = max(best, (float(np.mean(rule == human)), float(t)))
    return best


def measure(protocol: str, seed: int) -> dict:
    track, human_config = PROTOCOLS[protocol]
    demo_seed, _, _ = repetition_streams(repetition_seeds(seed, 10)[0])
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "demonstration.lfdemo"
        summary = run_demonstration(
            path, seed=demo_seed, track=track, human=human_config, fsync=False, memory=MEMORY
        )
        demo = load_demonstration(path)
    driving = np.asarray(demo.phases) == "drive"
    human = np.asarray(demo.commands, dtype=int)[driving]
    memory = np.asarray(demo.memory)[driving]
    blank = memory[:, 1] <= 0.0
    bearing = np.degrees([fresh_bearing_rad(m, MEMORY.bearing_range_deg) for m in memory])
    position = near_felt_features(np.asarray(demo.road_values)[driving])[:, 0] - 0.5
    map_agree, map_t = _best(np.where(blank, 0.0, bearing), human, np.arange(5.0, 41.0))
    near_agree, near_t = _best(position, human, np.arange(0.01, 0.405, 0.01))
    return {
        "protocol": protocol,
        "seed": seed,
        "demonstration_seed": int(demo_seed),
        "commands": summary.commands,
        "driving_cases": int(driving.sum()),
        "blank_cases": int(blank.sum()),
        "blank_labels": {NAMES[c]: int((human[blank] == c).sum()) for c in range(3)},
        "always_forward": float(np.mean(human == 0)),
        "map_bearing_agreement": map_agree,
        "map_bearing_threshold_deg": map_t,
        "near_felt_agreement": near_agree,
        "near_felt_threshold": round(near_t, 2),
    }


def table(rows: list[dict]) -> str:
    lines = [
        "| protocol | seed | commands | driving cases | blank (forward/left/right) |"
        " always forward | map bearing rule (best t) | near_felt rule (best t) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        b = r["blank_labels"]
        lines.append(
            f"| {r['protocol']} | {r['seed']} | {r['commands']} | {r['driving_cases']} |"
            f" {r['blank_cases']} ({b['forward']}/{b['left']}/{b['right']}) |"
            f" {r['always_forward']:.0%} | {r['map_bearing_agreement']:.0%}"
            f" ({r['map_bearing_threshold_deg']:.0f}°) | {r['near_felt_agreement']:.0%}"
            f" ({r['near_felt_threshold']:.2f}) |"
        )
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=HERE / "results")
    args = parser.parse_args()
    rows = [measure(p, s) for p in PROTOCOLS for s in (0, 1, 2)]
    args.out.mkdir(parents=True, exist_ok=True)
    atomic_write_text(args.out / "label_agreement.json", json.dumps(rows, indent=1) + "\n")
    text = "# The centreline human's commands against two inputs\n\n" + table(rows)
    atomic_write_text(args.out / "label_agreement.md", text)
    print(text)


if __name__ == "__main__":
    main()
