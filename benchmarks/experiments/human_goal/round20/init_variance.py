"""Does backprop's starting point bind what a demonstration teaches?

A controlled experiment on the selection's own trials (seed 0, repetitions 0-9: the paper's
training track 3 times each way and 10 validation loops once each way; no test loop, no testing
track). Each repetition's demonstration is made as the study makes it (its demonstration seed),
and the same cases are fitted ``--inits`` times by the configuration's learner, each fit from
its own starting weights: fit 0 with the study's learning seed (its laps must equal the study's
committed ones, lap for lap: the check that this is the study's machinery), fit j > 0 with the
learning seed ``SeedSequence([seed, j])``. Nothing else differs between the fits of a
repetition: not the demonstration, not the map, not the trials.

If the laps of a repetition change with the starting point as much as between repetitions, what
the demonstration teaches is not what binds: the fit's own noise is, and a learner that is
steadier in it (several fits voting) is the next design. If the fits of a repetition agree, the
demonstration binds.

    .venv/bin/python benchmarks/experiments/human_goal/round20/init_variance.py --workers 2

writes ``results/init_variance.md`` and ``.json`` (about 15 minutes on two cores).
"""

from __future__ import annotations

import argparse
import json
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from lfd_track.benchmark.runner import (
    learn_repetition,
    repetition_preset,
    repetition_seeds,
    repetition_streams,
    run_loop_trials,
    run_trials,
)
from lfd_track.methods.common import calibration_for
from lfd_track.study.spec import load_study
from lfd_track.utils.atomic import atomic_write_text

HERE = Path(__file__).resolve().parent
STUDY = HERE.parent / "round17" / "selection_round17.toml"
CONDITION = "centre.afresh.loop.unrec.nudge20.branch.cmdwin.turn.cb05"
STUDIED = HERE.parent / "round17" / "results" / "selection_round17" / CONDITION / "seed0"
SEED, REPETITIONS = 0, 10


def learning_seed(ga_seed: int, init: int) -> int:
    """The learning seed of fit ``init`` (0: the study's own)."""
    if init == 0:
        return ga_seed
    return int(np.random.SeedSequence([ga_seed, init]).generate_state(1, dtype=np.uint64)[0] >> 2)


def one_fit(index: int, seed: int, init: int) -> dict[str, Any]:
    """Learn repetition ``index`` (repetition seed ``seed``) with fit ``init``'s starting
    weights and drive its training-track runs and validation laps."""
    import tempfile

    import cv2

    cv2.setNumThreads(1)
    config = next(c.config for c in load_study(STUDY).conditions if c.name == CONDITION)
    demo_seed, ga_seed, trial_seed = repetition_streams(seed)
    preset = repetition_preset(config, seed)
    calibration = calibration_for(config.memory, preset, seed)
    extra = {} if calibration is None else {"calibration": calibration}
    with tempfile.TemporaryDirectory() as tmp:
        learned = learn_repetition(
            config,
            Path(tmp),
            demo_seed=demo_seed,
            ga_seed=learning_seed(ga_seed, init),
            preset=preset,
            **extra,
        )
    controller = learned.controller
    outcomes = run_trials(
        controller,
        trial_seed=trial_seed,
        test_tracks=(),
        trials_per_direction=config.trials_per_direction,
        preset=preset,
        repetition=index,
        tracks={"training"},
    )
    loops, _ = run_loop_trials(
        controller, trial_seed=trial_seed, config=config, repetition=index, preset=preset
    )
    return {
        "repetition": index,
        "init": init,
        "training": [bool(o.failure is None) for o in outcomes],
        "loops": [[o.track, o.direction, o.failure] for o in loops],
    }


def studied_outcomes() -> dict[int, tuple[list[bool], list[list[Any]]]]:
    """The committed selection study's outcomes per repetition (training, loops)."""
    data = json.loads((STUDIED / "results.json").read_text())
    out: dict[int, tuple[list[bool], list[list[Any]]]] = {}
    for o in data["outcomes"]:
        training, loops = out.setdefault(o["repetition"], ([], []))
        if o["track"] == "training":
            training.append(o["failure"] is None)
        elif o["track"] != "testing":
            loops.append([o["track"], o["direction"], o["failure"]])
    return out


def variance_split(laps: np.ndarray) -> tuple[float, float]:
    """(within-repetition, between-repetition) variance of ``laps`` (repetitions x fits): the
    mean over repetitions of the fits' variance, and the variance of the repetitions' means."""
    within = float(laps.var(axis=1, ddof=1).mean())
    between = float(laps.mean(axis=1).var(ddof=1))
    return within, between


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--inits", type=int, default=4, help="fits per repetition")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", type=Path, default=HERE / "results" / "init_variance")
    args = parser.parse_args()
    t0 = time.perf_counter()
    seeds = repetition_seeds(SEED, REPETITIONS)
    jobs = [(i, s, j) for j in range(args.inits) for i, s in enumerate(seeds)]
    with ProcessPoolExecutor(args.workers) as pool:
        results = list(pool.map(one_fit, *zip(*jobs, strict=True)))
    studied = studied_outcomes()
    mismatched = [
        r["repetition"]
        for r in results
        if r["init"] == 0 and (r["training"], r["loops"]) != studied[r["repetition"]]
    ]
    train = np.zeros((REPETITIONS, args.inits))
    loops = np.zeros((REPETITIONS, args.inits))
    for r in results:
        train[r["repetition"], r["init"]] = sum(r["training"])
        loops[r["repetition"], r["init"]] = sum(f is None for _, _, f in r["loops"])
    n_train = len(results[0]["training"])
    n_loops = len(results[0]["loops"])
    md = ["# Does backprop's starting point bind? (round 17's chosen configuration)", ""]
    md += [f"`{CONDITION}` (`../round17/selection_round17.toml`), seed {SEED}, repetitions"]
    md += [f"0-{REPETITIONS - 1}: each repetition's demonstration fitted {args.inits} times from"]
    md += ["its own starting weights (fit 0: the study's). Training-track runs of"]
    md += [f"{n_train} and validation laps of {n_loops} per repetition.", ""]
    if mismatched:
        md += [f"**Fit 0 does not reproduce the study** on repetitions {sorted(mismatched)}.", ""]
    else:
        md += ["Fit 0 reproduces the study's committed outcomes lap for lap.", ""]
    header = " | ".join(f"fit {j}" for j in range(args.inits))
    md += [f"| repetition | {header} | spread |", "|---" * (args.inits + 2) + "|"]
    for i in range(REPETITIONS):
        cells = " | ".join(f"{int(loops[i, j])}, {int(train[i, j])}" for j in range(args.inits))
        spread = int(loops[i].max() - loops[i].min())
        md += [f"| {i} | {cells} | {spread} |"]
    totals = " | ".join(
        f"**{int(loops[:, j].sum())}, {int(train[:, j].sum())}**" for j in range(args.inits)
    )
    md += [f"| all | {totals} | |", ""]
    md += ["Cells: validation laps (of 20), training-track runs (of 6).", ""]
    for name, laps in (("validation laps", loops), ("training-track runs", train)):
        within, between = variance_split(laps)
        md += [
            f"- {name}: variance between a repetition's fits {within:.2f}, of the repetitions'"
            f" means {between:.2f} (a fit's total over the 10 repetitions: "
            f"{', '.join(str(int(t)) for t in laps.sum(axis=0))})."
        ]
    md += ["", f"{(time.perf_counter() - t0) / 60:.0f} min on {args.workers} workers."]
    args.out.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(args.out.with_suffix(".md"), "\n".join(md) + "\n")
    atomic_write_text(args.out.with_suffix(".json"), json.dumps(results, indent=1) + "\n")
    print("\n".join(md))


if __name__ == "__main__":
    main()
