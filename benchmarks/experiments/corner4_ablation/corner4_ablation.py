"""Why corner 4 fails: the paper protocol with one thing changed at a time, corner-4 failures counted.

Corner 4 is the testing track's 135° corner, met last on every lap (both directions start on it).
Each condition below changes exactly one thing against the paper protocol (``paper``), and runs
the full protocol (fresh demonstration → evolution → 3 runs each way on the training track and 3
laps each way on the testing track) through ``lfd_track.benchmark.runner.run_benchmark`` for every
seed, with the same repetition seeds in every condition:

- ``wide``: field of view — the ``wide`` preset's fisheye (101° horizontal) instead of the paper's
  53° pinhole (``envs/wide.toml``);
- ``lookahead_0.6``: the demonstrator's bend cases — pure-pursuit lookahead 0.6 m instead of
  0.35 m, so the human starts bends earlier and turns in smaller, spread-out steps;
- ``turnaround_one_sided``: every turn-around to the left instead of alternating left and right;
- ``turnaround_unrecorded``: turn-arounds driven but not recorded as cases;
- ``control_0.2s``: a control period of 0.2 s instead of 0.4 s (≈ 5 cm or 11.5° per command).

For each condition the JSON holds training and testing successes (Wilson 95 % intervals), and per
testing direction how often corner 4 was reached and failed, by kind: ``timeout`` (the step budget
ran out, e.g. pivoting back and forth), ``reversed`` (turned the wrong way and drove back) and
``off_track``.

Run: ``.venv/bin/python benchmarks/experiments/corner4_ablation/corner4_ablation.py [--seeds 0] [--repetitions 10]
[--workers 2] [--only NAME ...]`` — writes ``benchmarks/experiments/corner4_ablation/results/corner4_ablation.json`` and
``benchmarks/experiments/corner4_ablation/results/corner4_ablation.md`` after every condition (a rerun with ``--only`` replaces
those conditions and keeps the others). ``--table-only`` rewrites the markdown from the JSON;
``--only wide --replay 2`` lists where each testing lap of the first two repetitions ended
(``benchmarks/experiments/corner4_ablation/results/corner4_replay_wide.md``).

Committed run: seed 0 × 10 repetitions, all six conditions in 44 minutes on a 2-core machine
shared with other jobs (load average 9–22); ``wide`` was rerun alone after per-corner counts were
added (same numbers, see the JSON's ``note``).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import os
import platform
import subprocess
import tempfile
import time
from pathlib import Path
from typing import Any

from lfd_track.benchmark.runner import BenchmarkConfig, RepetitionResult, run_benchmark
from lfd_track.benchmark.tables import FAILURE_KINDS
from lfd_track.demo.demonstrator import HumanConfig

RESULTS_DIR = Path(__file__).resolve().parent / "results"
JSON_PATH = RESULTS_DIR / "corner4_ablation.json"
MD_PATH = RESULTS_DIR / "corner4_ablation.md"
CORNER = "4"
#: A preset that differs from ``paper`` only in the control period (written to a temporary file).
CONTROL_PERIOD_PRESET = """name = "paper_control_0.2s"
description = "The paper's world with a 0.2 s control period (the only change)"
[rover]
control_period_s = 0.2
"""

#: name -> (what changes, BenchmarkConfig keyword changes). ``{tmp}`` is the temporary folder.
CONDITIONS: dict[str, tuple[str, dict[str, Any]]] = {
    "paper": ("nothing (the paper protocol)", {}),
    "wide": ("field of view: wide preset (fisheye, 101° horizontal)", {"preset": "wide"}),
    "lookahead_0.6": (
        "bend cases: demonstrator lookahead 0.6 m (0.35 m)",
        {"human": HumanConfig(lookahead_m=0.6)},
    ),
    "turnaround_one_sided": (
        "turn-arounds: always left (alternating)",
        {"human": HumanConfig(turnarounds="one_sided")},
    ),
    "turnaround_unrecorded": (
        "turn-arounds: not recorded (recorded)",
        {"human": HumanConfig(turnarounds="unrecorded")},
    ),
    "control_0.2s": (
        "control period 0.2 s (0.4 s)",
        {"preset": "{tmp}/paper_control_0.2s.toml"},
    ),
}


def wilson(successes: int, trials: int, z: float = 1.959964) -> list[float]:
    """Wilson score 95 % interval [low, high] of a success rate."""
    if trials == 0:
        return [0.0, 1.0]
    p = successes / trials
    denom = 1.0 + z * z / trials
    centre = (p + z * z / (2 * trials)) / denom
    half = z * math.sqrt(p * (1 - p) / trials + z * z / (4 * trials * trials)) / denom
    return [round(max(0.0, centre - half), 4), round(min(1.0, centre + half), 4)]


def summarise(reps: list[RepetitionResult]) -> dict[str, Any]:
    """Success counts and corner-4 failures by kind and direction from repetition results."""
    outcomes = [o for r in reps for o in r.outcomes]
    out: dict[str, Any] = {}
    for track in ("training", "testing"):
        trials = [o for o in outcomes if o.track == track]
        wins = sum(o.success for o in trials)
        out[track] = {"successes": wins, "trials": len(trials), "ci95": wilson(wins, len(trials))}
    corner4: dict[str, Any] = {}
    for direction in ("ccw", "cw"):
        laps = [o for o in outcomes if o.track == "testing" and o.direction == direction]
        index = laps[0].corner_order.index(CORNER) if laps else 0
        failed = [o for o in laps if o.charged_corner == CORNER]
        corner4[direction] = {
            "laps": len(laps),
            "reached": sum(len(o.corners_negotiated) >= index for o in laps),
            "failures": len(failed),
            "kinds": {kind: sum(o.failure == kind for o in failed) for kind in FAILURE_KINDS},
        }
    total = {
        "reached": sum(d["reached"] for d in corner4.values()),
        "failures": sum(d["failures"] for d in corner4.values()),
        "kinds": {k: sum(d["kinds"][k] for d in corner4.values()) for k in FAILURE_KINDS},
    }
    corner4["total"] = total
    out["corner4"] = corner4
    other = [o for o in outcomes if o.track == "testing" and o.charged_corner not in (None, CORNER)]
    out["testing_failures_before_corner4"] = len(other)
    # Every testing corner, for where the failures went when corner 4 is not the story.
    corners: dict[str, Any] = {}
    for direction in ("ccw", "cw"):
        laps = [o for o in outcomes if o.track == "testing" and o.direction == direction]
        order = laps[0].corner_order if laps else ()
        corners[direction] = {
            label: {
                "reached": sum(len(o.corners_negotiated) >= i for o in laps),
                "failures": sum(o.charged_corner == label for o in laps),
            }
            for i, label in enumerate(order)
        }
    out["testing_corners"] = corners
    out["demo_cases_mean"] = round(sum(r.demo["cases"] for r in reps) / len(reps), 1)
    out["training_accuracy_mean"] = round(sum(r.training_accuracy for r in reps) / len(reps), 4)
    return out


def markdown(data: dict[str, Any]) -> str:
    """The table of the README: one row per condition."""
    lines = [
        f"Seed{'s' if len(data['seeds']) > 1 else ''} {', '.join(map(str, data['seeds']))} × "
        f"{data['repetitions']} repetitions per "
        "condition (training: 6 runs, testing: 6 laps per repetition). Corner-4 columns: "
        "failures / times reached, and the failures by kind.",
        "",
        "| condition | changes | training | testing (95 % CI) | corner 4 ccw | corner 4 cw "
        "| corner 4 failure rate (95 % CI) | timeouts | reversals | off track | wall |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for name, row in data["conditions"].items():
        tr, te, c4 = row["training"], row["testing"], row["corner4"]
        low, high = te["ci95"]
        fails, arrivals = c4["total"]["failures"], c4["total"]["reached"]
        f_low, f_high = wilson(fails, arrivals)
        lines.append(
            f"| {name} | {row['changes']} | {tr['successes']}/{tr['trials']} "
            f"| {te['successes']}/{te['trials']} ({100 * low:.0f}–{100 * high:.0f} %) "
            f"| {c4['ccw']['failures']}/{c4['ccw']['reached']} "
            f"| {c4['cw']['failures']}/{c4['cw']['reached']} "
            f"| {fails}/{arrivals} = {100 * fails / max(arrivals, 1):.0f} % "
            f"({100 * f_low:.0f}–{100 * f_high:.0f} %) "
            f"| {c4['total']['kinds']['timeout']} | {c4['total']['kinds']['reversed']} "
            f"| {c4['total']['kinds']['off_track']} | {row['wall_s']:.0f} s |"
        )
    return "\n".join(lines) + "\n"


def replay(name: str, seed: int, count: int) -> str:
    """Markdown list of where each testing lap of the first ``count`` repetitions ended."""
    from lfd_track.benchmark.runner import repetition_seeds, run_repetition

    changes, fields = CONDITIONS[name]
    lines = [f"Condition `{name}` ({changes}), seed {seed}: testing laps of the first {count} "
             "repetitions — outcome, failure kind, corner charged, commands, final (x, y) [m] "
             "(laps start on corner 4 at (0, 0)).", ""]  # fmt: skip
    with tempfile.TemporaryDirectory() as tmp:
        Path(tmp, "paper_control_0.2s.toml").write_text(CONTROL_PERIOD_PRESET)
        fields = {k: v.format(tmp=tmp) if isinstance(v, str) else v for k, v in fields.items()}
        config = dataclasses.replace(BenchmarkConfig(seed=seed), **fields)
        for index, rep_seed in enumerate(repetition_seeds(seed, count)):
            result = run_repetition(index, rep_seed, config, tmp)
            for o in result.outcomes:
                if o.track != "testing" or o.trajectory is None:
                    continue
                x, y = (float(v) for v in o.trajectory[-1][:2])
                lines.append(
                    f"- rep {index} {o.direction} lap {o.trial}: "
                    f"{'success' if o.success else o.failure}, corner {o.charged_corner}, "
                    f"{o.steps} commands, ends at ({x:.2f}, {y:.2f})"
                )
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0])
    parser.add_argument("--repetitions", type=int, default=10)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--only", nargs="+", choices=sorted(CONDITIONS))
    parser.add_argument(
        "--table-only", action="store_true", help="rewrite the markdown from the JSON, run nothing"
    )
    parser.add_argument(
        "--replay",
        type=int,
        default=0,
        metavar="N",
        help="instead: list where the testing laps of the first N repetitions of each --only "
        "condition ended (writes corner4_replay_<name>.md)",
    )
    args = parser.parse_args()
    if args.replay:
        for name in args.only or ["wide"]:
            text = replay(name, args.seeds[0], args.replay)
            (RESULTS_DIR / f"corner4_replay_{name}.md").write_text(text)
            print(text)
        return
    if args.table_only:
        MD_PATH.write_text(markdown(json.loads(JSON_PATH.read_text())))
        return
    names = args.only or list(CONDITIONS)
    data: dict[str, Any] = {"seeds": args.seeds, "repetitions": args.repetitions, "conditions": {}}
    if args.only and JSON_PATH.exists():
        previous = json.loads(JSON_PATH.read_text())
        if previous.get("seeds") == args.seeds and previous.get("repetitions") == args.repetitions:
            data = previous
    try:
        commit = subprocess.run(
            ["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, check=False
        ).stdout.strip()
    except OSError:
        commit = ""
    data.update(
        {
            "commit": commit,
            "machine": platform.platform(),
            "cpus": os.cpu_count(),
        }
    )
    RESULTS_DIR.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        Path(tmp, "paper_control_0.2s.toml").write_text(CONTROL_PERIOD_PRESET)
        for name in names:
            changes, fields = CONDITIONS[name]
            fields = {k: v.format(tmp=tmp) if isinstance(v, str) else v for k, v in fields.items()}
            t0 = time.perf_counter()
            load0 = os.getloadavg()[0]
            reps: list[RepetitionResult] = []
            for seed in args.seeds:
                config = dataclasses.replace(
                    BenchmarkConfig(repetitions=args.repetitions, seed=seed), **fields
                )
                work = Path(tmp, name, f"seed{seed}")
                reps += run_benchmark(config, work, workers=args.workers)
            row = {"changes": changes, **summarise(reps)}
            row["wall_s"] = round(time.perf_counter() - t0, 1)
            row["load_average_at_start"] = round(load0, 2)
            data["conditions"][name] = row
            # Keep the table in CONDITIONS order whatever order the runs came in.
            data["conditions"] = {
                n: data["conditions"][n] for n in CONDITIONS if n in data["conditions"]
            }
            JSON_PATH.write_text(json.dumps(data, indent=2) + "\n")
            MD_PATH.write_text(markdown(data))
            c4 = row["corner4"]["total"]
            print(
                f"{name}: training {row['training']['successes']}/{row['training']['trials']}, "
                f"testing {row['testing']['successes']}/{row['testing']['trials']}, corner 4 "
                f"{c4['failures']}/{c4['reached']} {c4['kinds']} ({row['wall_s']:.0f} s)",
                flush=True,
            )
    print(markdown(data))


if __name__ == "__main__":
    main()
