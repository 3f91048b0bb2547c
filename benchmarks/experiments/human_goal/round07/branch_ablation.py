"""Does the branch side make round 7's winner turn round on the paper's training track?

Round 7's winner laps the training track less often than round 5's (142 against 164 of 180 on
the test study's repetitions), most of its failures reversals after the last corner
(``../test_round7/README.md``). A controlled experiment on the training track only (no test loop,
no testing track): seed 0, repetitions 0-9 (0-3 are ``selection_round7.toml``'s validation
repetitions, and 0-9 the test study's seed 0, whose training-track runs only are driven here:
a repetition's seeds do not depend on how many follow); each repetition's controller learned by
the study's own machinery (``learn_repetition``), each driven 3 times each way on the training
track (``run_trials``, the study's world seeds), three ways:

* ``as learned`` — the controller itself (for repetitions 0-3 its outcomes are checked against
  the selection study's ``results.json``, trial by trial);
* ``wrapped`` — the same network through this script's wrapper, inputs untouched (checks that the
  wrapper changes nothing);
* ``branch held at none`` — the wrapper with the fourth input held at 0.5 (no side) at every
  step; the map and the other three inputs as they are.

If holding the input removes the reversals, the branch side read near the track's end (or where a
strip passes felt of another leg) is what turns it round. Protocol fixed before running; written
to ``results/branch_ablation.md`` beside this file.

    .venv/bin/python benchmarks/experiments/human_goal/round07/branch_ablation.py

The same measurement of another study's condition and seed (``--study FILE --condition NAME
--seed N --out DIR``; the outcomes "as learned" are checked against that study's committed
``results.json`` for its repetitions): round 9's winner on its test study's seeds
(``../round09/README.md``).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from lfd_track.benchmark.runner import repetition_seeds
from lfd_track.envs.presets import load_preset
from lfd_track.policy.branch_side import UNKNOWN
from lfd_track.policy.controller import Controller
from lfd_track.policy.map_geometry import MapGeometry
from lfd_track.study.spec import load_study
from lfd_track.utils.atomic import atomic_write_text

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
from study_repetition import learned_repetition, training_runs  # noqa: E402  (one folder up)

STUDY = HERE / "selection_round7.toml"
CONDITION = "centre.afresh.loop.unrec.nudge20.branch"
STUDIED = HERE / "results" / "selection_round7" / CONDITION / "seed0" / "results.json"
VARIANTS = ("as learned", "wrapped", "branch held at none")


@dataclasses.dataclass
class Wrapped:
    """Drives ``controller``'s network on its own perception; with ``hold``, the fourth map
    input is replaced by :data:`UNKNOWN` before every decision."""

    controller: Controller
    preset: Any
    hold: bool

    def perception(self) -> Any:
        preset = load_preset(self.preset) if isinstance(self.preset, str) else self.preset
        return self.controller.perception(world_geometry=MapGeometry.from_preset(preset))

    def commander(self) -> Any:
        commander = self.controller.commander()
        act = commander.act_on_values

        def propose(moment: Any) -> Any:
            x = np.array(moment.policy_inputs, dtype=np.float64)
            if self.hold:
                x[-1] = UNKNOWN
            return act(x)

        commander.propose = propose  # type: ignore[method-assign]
        return commander


def outcome_row(outcomes: list[Any]) -> dict[str, Any]:
    kinds: dict[str, int] = {}
    for o in outcomes:
        if not o.success:
            kinds[o.failure] = kinds.get(o.failure, 0) + 1
    return {
        "laps": sum(o.success for o in outcomes),
        "trials": len(outcomes),
        "failures": kinds,
        "outcomes": [(o.direction, o.success, o.failure, o.steps) for o in outcomes],
    }


def main() -> None:
    import cv2

    cv2.setNumThreads(1)
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repetitions", type=int, default=10, help="first N of the seed")
    parser.add_argument("--study", type=Path, default=STUDY, help="the study file")
    parser.add_argument("--condition", default=CONDITION, help="its condition")
    parser.add_argument("--seed", type=int, default=0, help="its seed")
    parser.add_argument("--out", type=Path, default=HERE / "results")
    args = parser.parse_args()
    study = load_study(args.study)
    base = next(c for c in study.conditions if c.name == args.condition).config
    config = dataclasses.replace(base, seed=args.seed, repetitions=study.repetitions)
    if args.study == STUDY and args.condition == CONDITION and args.seed == 0:
        studied_path, stem = STUDIED, "branch_ablation"
    else:
        folder = args.study.parent / "results" / args.study.stem / args.condition
        studied_path = folder / f"seed{args.seed}" / "results.json"
        stem = f"branch_ablation_{args.condition}_seed{args.seed}"
    studied = json.loads(studied_path.read_text(encoding="utf-8"))["outcomes"]
    t0 = time.perf_counter()
    rows: list[dict[str, Any]] = []
    for index, seed in enumerate(repetition_seeds(args.seed, args.repetitions)):
        with learned_repetition(config, seed) as repetition:
            pass
        controller = repetition.learned.controller
        row: dict[str, Any] = {"repetition": index}
        for variant in VARIANTS:
            driver = controller if variant == "as learned" else None
            if driver is None:
                hold = variant == "branch held at none"
                driver = Wrapped(controller, repetition.preset, hold=hold)
            row[variant] = outcome_row(training_runs(driver, repetition, config, index))
        mine = [o for o in studied if o["track"] == "training" and o["repetition"] == index]
        row["study_laps"] = sum(o["success"] for o in mine) if mine else None
        row["same_as_study"] = not mine or [(o["success"], o["steps"]) for o in mine] == [
            (s, n) for _, s, _, n in row["as learned"]["outcomes"]
        ]
        rows.append(row)
        print(f"repetition {index}: {time.perf_counter() - t0:.0f} s", flush=True)
    wall = time.perf_counter() - t0
    md = [f"# `{args.condition}` on the training track with its branch side held at none", ""]
    md += [f"Seed {args.seed}, repetitions 0-{len(rows) - 1}, 3 runs each way;"]
    md += [f"{wall / 60:.0f} min on one core: `.venv/bin/python"]
    md += ["benchmarks/experiments/human_goal/round07/branch_ablation.py`"]
    if stem != "branch_ablation":
        md[-1] += f" `--study {args.study} --condition {args.condition} --seed {args.seed}`"
    md[-1] += "."
    md += ["", "| repetition | as in the study | " + " | ".join(VARIANTS) + " |"]
    md += ["|---|---|" + "---|" * len(VARIANTS)]

    def cell(r: dict[str, Any]) -> str:
        kinds = ", ".join(f"{n} {k}" for k, n in sorted(r["failures"].items()))
        return f"{r['laps']}/{r['trials']}" + (f" ({kinds})" if kinds else "")

    for row in rows:
        same = "" if row["same_as_study"] else " (differs)"
        cells = " | ".join(cell(row[v]) for v in VARIANTS)
        study_laps = "–" if row["study_laps"] is None else f"{row['study_laps']}/6{same}"
        md += [f"| {row['repetition']} | {study_laps} | {cells} |"]
    totals = {v: sum(r[v]["laps"] for r in rows) for v in VARIANTS}
    trials = sum(r[VARIANTS[0]]["trials"] for r in rows)
    md += ["| all | | " + " | ".join(f"{totals[v]}/{trials}" for v in VARIANTS) + " |", ""]
    args.out.mkdir(parents=True, exist_ok=True)
    atomic_write_text(args.out / f"{stem}.md", "\n".join(md) + "\n")
    atomic_write_text(
        args.out / f"{stem}.json", json.dumps({"rows": rows, "wall_s": round(wall, 1)})
    )
    print("\n".join(md))


if __name__ == "__main__":
    main()
