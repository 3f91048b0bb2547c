"""Where at a corner do the learned policy's commands part from the map rule's?

Round 3's winner ``centre.afresh.loop.hg1`` (``round03/selection_round3.toml``: a 3-5-3 network
on the three ``fresh_felt`` inputs, fitted by backprop to the centreline human's demonstration
and one round of HG-DAgger interventions) laps fewer loops than the fresh-felt rule on the same
map (``test_round3/README.md``), mainly at corners past 100°. This measures, step by step, where
their commands differ, on validation loops only (no test loop, no testing track).

Protocol (fixed before running). Seed 0, repetitions 0-3 of the round-3 selection study: each
repetition's streams (``repetition_streams``) and its controller learned by the study's own
machinery (``learn_repetition``, the method registry); then its 10 validation loops, drawn and
admitted by the teacher's check as ``run_loop_trials`` does, each lapped once each way
(``run_trial``, the loop's world seed) twice: driven by the learned policy with the rule as a
shadow (computing its command on the same inputs, never steering), then driven by the rule with
the learned policy as the shadow. Both read the same perception (the controller's frozen library
and its map). The rule is ``FreshFeltRule`` with the picture-steering human's 20° and the shipped
``FreshFeltConfig`` (as ``../generalization/rules.py`` builds its ``map-rule``); for a condition
whose map has other settings (round 7's ``branch_side``), that map (the rule then pivots toward
the branch side while the map is blank; the tables read the map's first three inputs). Per step: the
map's inputs (bearing, clipped to ±30° by ``bearing_range_deg``; amount of fresh felt, 0 =
blank map; distance of its centre over ``reach_m`` = 0.6 m, 1 = beyond reach, found by the
further look), both commands, the lap's outcome, steps to the lap's end, the loop's sharpest turn.
Regions: blank (amount 0) or not; |bearing| <10, 10-20, 20-30, 30 (saturated: 30° or more; the
input cannot tell 40° from 30°, so the bins 20-40 and >40 become 20-30 and saturated); distance
<0.25, 0.25-0.5, 0.5-0.75, 0.75-1, 1; amount <0.25, 0.25-0.5, 0.5-1, 1; sharpest turn <=60,
60-100, 100-135, >135°; the last 10 steps of failed laps, their steps 11-30 before the end, their
earlier steps, successful laps. Per region: agreement, the three ways of parting (learned forward
where the rule pivots, the reverse, opposite pivots) and how often the learned policy pivots away
from the side the fresh felt lies on; confusion matrices, blank and not; and (added after a
2-loop check of the script, before the full run) how often each pivots by |bearing| in 5° steps.
The learned laps are checked against ``round03/results/selection_round3/.../results.json``
(outcome and steps per lap). Added after the first full run, which showed the learned policy
pivoting away from fresh felt 30° or more off and on a blank map: the same regions counted over
the cases each repetition's network was fitted to (the human's demonstration and
interventions). The JSON keeps every lap with its commands as letters (F, L, R) and the map's
inputs per step in thousandths.

    .venv/bin/python benchmarks/experiments/human_goal/where_they_part.py

``--test-split`` with a frozen configuration's study on the test split (e.g.
``../goal/chosen.toml``): the rule beside the learned policy on those trials, reading the same
inputs, chosen on nothing (written to ``where_they_part_STUDY_NAME_seedS.md`` and ``.json``).
``--seed S`` (one of the study's seeds; default 0), ``--repetitions N`` (its first N),
``--loops K`` (first K loops each), ``--out DIR`` (default
``results/`` beside this file: ``where_they_part.md`` and ``.json``); ``--study FILE
--condition NAME`` learns another selection study's condition on its own validation
repetitions (written to ``where_they_part_NAME.md`` and ``.json``), e.g. round 5's winner.

Length/time: about 400 lines, over this folder's usual length for the step tables and the
checks; the full run (4 repetitions: 4 controllers learned, 80 teacher checks, 160 laps) took
5 min on one shared core.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import shlex
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
from study_repetition import learned_repetition  # this folder (the script's own)

from lfd_track.benchmark.loops import MAX_DRAWS_PER_LOOP, loop_draws, loop_facts, teacher_lap
from lfd_track.benchmark.runner import (
    repetition_seeds,
    run_trial,
)
from lfd_track.dataset import load_demonstration
from lfd_track.envs.track_env import LfDTrackEnv
from lfd_track.policy.controller import Controller
from lfd_track.policy.memory import fresh_bearing_rad
from lfd_track.policy.memory_config import FreshFeltConfig
from lfd_track.study.spec import load_study
from lfd_track.teaching.handwritten import FreshFeltRule, FreshFeltRuleConfig
from lfd_track.teaching.scripted import HumanConfig
from lfd_track.utils.atomic import atomic_write_text
from lfd_track.world.loops import TURN_BIN_LABELS, turn_bin

HERE = Path(__file__).resolve().parent
COMMAND = "benchmarks/experiments/human_goal/where_they_part.py"
STUDY = HERE / "round03" / "selection_round3.toml"
CONDITION = "centre.afresh.loop.hg1"
STUDIED = HERE / "round03" / "results" / "selection_round3" / CONDITION / "seed0" / "results.json"
RULE = FreshFeltRuleConfig(turn_deg=HumanConfig().picture_turn_deg, memory=FreshFeltConfig())
LETTERS, NAMES = "FLR", ("forward", "left", "right")
INPUTS = ("bearing_in", "amount_in", "distance_in")  # the fresh_felt map's three inputs
BEARING_EDGES = ((0, 10, 20, 30), (0, 5, 10, 15, 20, 25, 30))  # protocol bins; 5° profile
DISTANCE_EDGES = (0.0, 0.25, 0.5, 0.75, 1.0, np.inf)  # 1: beyond reach_m (the further look)
AMOUNT_EDGES = (0.0, 0.25, 0.5, 1.0, np.inf)  # 1: full
COLUMNS: tuple[str, ...] = (
    "agree",
    "learned pivots",
    "rule pivots",
    "learned forward, rule pivots",
)
COLUMNS += ("learned pivots, rule forward", "opposite pivots", "learned pivots away from the felt")
LABEL_REGIONS = ("map blank", "0-10° off", "10-20° off", "20-30° off", "30° or more off")
PHASES = {"drive": "demonstration, driving", "turnaround": "demonstration, turn-arounds"}
PHASES |= {"intervention": "interventions", "correction": "interventions"}
#: The human's labels on a blank map while the branch side gives a side (``human_labels``' key).
BRANCH_LABELS = "blank map, branch side given"
SPLIT = "validation"  # the procedural loops' split the study drives (the report names it)
#: The command line's arguments after the script's name, as the report quotes them.
ARGS = "".join(f" {shlex.quote(a)}" for a in sys.argv[1:])
CHECK = ("laps", "lapped here", "lapped in the study", "same outcome", "same steps")


@dataclasses.dataclass
class Shadowed:
    """Drives by ``driver`` ("learned" or "rule") on the controller's perception, asking the other
    on the very same inputs at each step (never steering); logs the inputs and both commands.
    ``run_trial`` drives it as it drives a controller (``perception()``, ``commander()``)."""

    controller: Controller
    driver: str
    log: list = dataclasses.field(default_factory=list)
    learned: Any = None
    rule: Any = None

    def perception(self) -> Any:
        return self.controller.perception()

    def commander(self) -> Shadowed:
        self.learned, self.rule = self.controller.commander(), FreshFeltRule(RULE)
        return self

    def reset(self) -> None:
        self.learned.reset()
        self.rule.reset()
        self.log.clear()

    def propose(self, moment: Any) -> Any:
        learned, rule = self.learned.propose(moment), self.rule.propose(moment)
        inputs = np.asarray(moment.policy_inputs, dtype=float)
        n_map = RULE.memory.n_inputs  # the map's inputs come last: bearing, amount, distance first
        memory = inputs[len(inputs) - n_map :]
        branch = float(memory[3]) if n_map > 3 and RULE.memory.branch_side else 0.5
        self.log.append((memory[:3], learned, rule, branch))
        return learned if self.driver == "learned" else rule


def lap_record(name: str, direction: str, driver: str, info: dict, log: list) -> dict:
    sharpest, _ = loop_facts(name)
    failure = info["failure"] if info["success"] or info["failure"] else "timeout"
    return dict(
        track=name, direction=direction, driver=driver, success=bool(info["success"]),
        failure=failure, steps=len(log), sharpest_turn_deg=round(float(sharpest), 1),
        turn_bin=turn_bin(sharpest), inputs=np.array([x for x, *_ in log]).reshape(-1, 3),
        learned="".join(LETTERS[int(c)] for _, c, *_ in log),
        rule="".join(LETTERS[int(c)] for _, _, c, _ in log),
        branch=np.array([b for *_, b in log]),
    )  # fmt: skip


def table(head: tuple[str, ...], rows: list[list[Any]]) -> list[str]:
    """A markdown table."""
    lines = ["| " + " | ".join(head) + " |", "|---" * len(head) + "|"]
    return lines + ["| " + " | ".join(str(x) for x in row) + " |" for row in rows]


def pivots(command: np.ndarray, left: np.ndarray, right: np.ndarray) -> tuple[np.ndarray, ...]:
    """Masks of the pivots toward a side and away from it, the side left or right at each step
    (commands 1 left, 2 right)."""
    toward = ((command == 1) & left) | ((command == 2) & right)
    away = ((command == 1) & right) | ((command == 2) & left)
    return toward, away


def human_labels(folder: Path) -> dict[str, dict[str, list[int]]]:
    """The human's commands the network was fitted to (the demonstration, the interventions), by
    where the fresh felt lay: [cases, forward, toward the felt's side, away from it] per region
    (blank: the side it last lay on, which is what the bearing input then holds)."""
    out: dict[str, dict[str, list[int]]] = {}
    for path in sorted(folder.glob("*.lfdemo")):
        demo = load_demonstration(path)
        mem, cmd = np.asarray(demo.memory, dtype=float), np.asarray(demo.commands)
        phases = np.asarray(demo.phases)
        if RULE.memory.branch_side and mem.shape[1] > 3:  # blank map, the branch side given
            side = mem[:, 3]
            given = (mem[:, 1] <= 0.0) & (side != 0.5)
            toward_side, away_side = pivots(cmd, side > 0.5, side < 0.5)
            by_phase = out.setdefault(BRANCH_LABELS, {})
            for phase in sorted(set(phases)):
                m = (phases == phase) & given
                counts = (m, m & (cmd == 0), m & toward_side, m & away_side)
                row = by_phase.get(PHASES.get(phase, phase), [0] * 4)
                by_phase[PHASES.get(phase, phase)] = [
                    a + int(b.sum()) for a, b in zip(row, counts, strict=True)
                ]
        bearing = np.degrees([fresh_bearing_rad(x, RULE.memory.bearing_range_deg) for x in mem])
        ab, sat = np.abs(bearing), (mem[:, 0] <= 0.0) | (mem[:, 0] >= 1.0)
        region = np.select([mem[:, 1] <= 0.0, sat, ab < 10, ab < 20], [0, 4, 1, 2], 3)
        toward, away = pivots(cmd, bearing > 0, bearing < 0)
        for phase in sorted(set(phases)):
            rows = out.setdefault(PHASES.get(phase, phase), {r: [0] * 4 for r in LABEL_REGIONS})
            for k, name in enumerate(LABEL_REGIONS):
                m = (phases == phase) & (region == k)
                counts = (m, m & (cmd == 0), m & toward, m & away)
                rows[name] = [a + int(b.sum()) for a, b in zip(rows[name], counts, strict=True)]
    return out


def run_repetition(index: int, seed: int, config: Any, loops: int) -> dict:
    """Learn the repetition's controller, then lap its validation loops both ways, twice."""
    import cv2

    cv2.setNumThreads(1)
    t0 = time.perf_counter()
    with learned_repetition(config, seed) as repetition:
        labels = human_labels(repetition.folder)
    preset, trial_seed = repetition.preset, repetition.trial_seed
    controller = repetition.learned.controller
    controller.learn = config.keep_learning
    learning_s = time.perf_counter() - t0
    laps: list[dict] = []
    draws, drawn, admitted = loop_draws(trial_seed, config.random_split), 0, 0
    while admitted < loops:  # run_loop_trials' draw and admission, two drivers per lap
        assert drawn < MAX_DRAWS_PER_LOOP * loops, "the teacher laps too few loops"
        name, worlds = next(draws)
        drawn += 1
        envs = {
            d: (LfDTrackEnv(track=name, reverse=r, preset=preset), w)
            for r, d, w in ((False, "ccw", worlds[0]), (True, "cw", worlds[1]))
        }
        teacher = [teacher_lap(env, world)["success"] for env, world in envs.values()]
        if all(teacher):
            admitted += 1
            for direction, (env, world) in envs.items():
                for driver in ("learned", "rule"):
                    shadowed = Shadowed(controller, driver)
                    # run_trial drives anything with perception() and commander()
                    info, _, steps = run_trial(env, shadowed, seed=world)  # type: ignore[arg-type]
                    assert steps == len(shadowed.log)
                    laps.append(lap_record(name, direction, driver, info, shadowed.log))
                    laps[-1]["repetition"] = index
        for env, _ in envs.values():
            env.close()
    print(f"repetition {index}: {len(laps)} laps, {time.perf_counter() - t0:.0f} s", flush=True)
    return {
        "repetition": index,
        "drawn": drawn,
        "human_labels": labels,
        "laps": laps,
        "timing_s": {"learning": round(learning_s, 1), "total": round(time.perf_counter() - t0, 1)},
    }


def check_against_study(laps: list[dict]) -> dict:
    """Per repetition: do the learned laps match the study's (outcome, failure, steps)?"""
    studied = {
        (o["repetition"], o["track"], o["direction"]): o
        for o in json.loads(STUDIED.read_text())["outcomes"]
    }
    rows: dict[str, dict] = {}
    for lap in (x for x in laps if x["driver"] == "learned"):
        row = rows.setdefault(str(lap["repetition"]), dict.fromkeys(CHECK, 0))
        o = studied[(lap["repetition"], lap["track"], lap["direction"])]
        row["laps"] += 1
        row["lapped here"] += lap["success"]
        row["lapped in the study"] += o["success"]
        row["same outcome"] += o["success"] == lap["success"] and o["failure"] == lap["failure"]
        row["same steps"] += o["steps"] == lap["steps"]
    return rows


def step_table(laps: list[dict]) -> dict[str, np.ndarray]:
    """Every step of ``laps`` as columns; bearing in degrees, left positive."""
    inputs = np.concatenate([lap["inputs"] for lap in laps])
    range_deg = RULE.memory.bearing_range_deg
    return {
        "enc": inputs[:, 0],
        "amount": inputs[:, 1],
        "dist": inputs[:, 2],
        "bearing": np.degrees([fresh_bearing_rad(x, range_deg) for x in inputs]),
        "learned": np.array([LETTERS.index(c) for lap in laps for c in lap["learned"]]),
        "rule": np.array([LETTERS.index(c) for lap in laps for c in lap["rule"]]),
        "success": np.concatenate([[lap["success"]] * lap["steps"] for lap in laps]),
        "to_end": np.concatenate([np.arange(lap["steps"], 0, -1) for lap in laps]),
        "turn": np.concatenate([[lap["turn_bin"]] * lap["steps"] for lap in laps]),
        "branch": np.concatenate([lap["branch"] for lap in laps]),
    }


def binned(
    x: np.ndarray, edges: tuple[float, ...], unit: str = "", top: str = ""
) -> dict[str, np.ndarray]:
    """Masks of ``x`` in ``[edges[i], edges[i + 1])``; an open last bin is ``f"{low} {top}"``."""
    last = len(edges) - 2
    return {
        (f"{lo:g} {top}" if i == last and hi == np.inf else f"{lo:g}-{hi:g}{unit}"): (
            (x >= lo) & (x < hi)
        )
        for i, (lo, hi) in enumerate(zip(edges[:-1], edges[1:], strict=True))
    }


def regions(t: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The rows of the agreement table: name -> mask of steps."""
    blank = t["amount"] <= 0.0
    sat = (t["enc"] <= 0.0) | (t["enc"] >= 1.0)  # 30° or more: the input cannot say how far
    rows = {"all steps": np.ones_like(blank), "map blank": blank, "map not blank": ~blank}
    for edges in BEARING_EDGES:  # the protocol's bins, then the 5° profile
        for label, m in binned(np.abs(t["bearing"]), edges, "°").items():
            rows[f"not blank, {label} off"] = ~blank & m & ~sat
        rows.setdefault("not blank, 30° or more off (saturated)", ~blank & sat)
    for label, m in binned(t["dist"], DISTANCE_EDGES, top="(beyond reach_m)").items():
        rows[f"not blank, distance {label}"] = ~blank & m
    for label, m in binned(t["amount"], AMOUNT_EDGES, top="(full)").items():
        rows[f"not blank, amount {label}"] = ~blank & m
    for label in TURN_BIN_LABELS:
        rows[f"sharpest turn {label}"] = t["turn"] == label
    fail, end = ~t["success"].astype(bool), t["to_end"]
    rows["failed laps, last 10 steps"] = fail & (end <= 10)
    rows["failed laps, 11-30 steps before the end"] = fail & (end > 10) & (end <= 30)
    rows["failed laps, earlier steps"] = fail & (end > 30)
    rows["successful laps"] = ~fail
    return rows


def parting(t: dict[str, np.ndarray], m: np.ndarray) -> dict[str, Any]:
    """Steps, agreement, how often each pivots and the ways of parting among the steps ``m``."""
    lc, rc, b = t["learned"][m], t["rule"][m], t["bearing"][m]
    _, away = pivots(lc, b > 0, b < 0)  # from the side the fresh felt lies on
    shares: tuple[np.ndarray, ...] = (
        lc == rc,
        lc != 0,
        rc != 0,
        (lc == 0) & (rc != 0),
        (lc != 0) & (rc == 0),
    )
    shares += ((lc != 0) & (rc != 0) & (lc != rc), away)
    n = int(m.sum())
    return {"steps": n} | {
        c: round(float(v.mean()), 4) if n else None for c, v in zip(COLUMNS, shares, strict=True)
    }


def pct(x: float | None) -> str:
    return "–" if x is None else f"{100 * x:.0f} %"


def report(
    done: list[dict], reps: int, loops: int, wall_s: float, seed: int = 0
) -> tuple[str, dict]:
    laps = [lap for d in done for lap in d["laps"]]
    check = check_against_study(laps)
    out: dict[str, Any] = dict(
        study=os.path.relpath(STUDY, HERE), condition=CONDITION, seed=seed, repetitions=reps,
        loops_per_repetition=loops, rule=dataclasses.asdict(RULE), wall_s=round(wall_s, 1),
        check_against_study=check, by_driver={},
    )  # fmt: skip
    md = [f"# Where the learned policy's commands part from the map rule's ({CONDITION})", ""]
    md += [f"Seed {seed}, repetitions 0-{reps - 1}, {loops} {SPLIT} loops each, once each way;"]
    md += [f"{wall_s / 60:.0f} min on one core: `.venv/bin/python {COMMAND}{ARGS}`.", ""]
    md += [f"## The learned laps against the selection study's ({STUDY.name})", ""]
    md += table(("repetition", *CHECK), [[k] + [r[c] for c in CHECK] for k, r in check.items()])
    by_turn = []
    for driver in ("learned", "rule"):
        mine = [x for x in laps if x["driver"] == driver]
        some = [mine] + [[x for x in mine if x["turn_bin"] == b] for b in TURN_BIN_LABELS]
        by_turn.append([driver] + [f"{sum(x['success'] for x in s)}/{len(s)}" for s in some])
    md += ["", "## Laps by sharpest turn (the same loops, library and map)", ""]
    md += table(("driver", "all", *TURN_BIN_LABELS), by_turn)
    won = {(x["repetition"], x["track"], x["direction"], x["driver"]): x["success"] for x in laps}
    both = [(won[k], won[k[:3] + ("rule",)]) for k in won if k[3] == "learned"]
    out["paired_outcomes"] = {
        f"learned {'laps' if a else 'fails'}, rule {'laps' if b else 'fails'}": both.count((a, b))
        for a in (True, False)
        for b in (True, False)
    }
    md += ["", "The same loop the same way: "]
    md[-1] += "; ".join(f"{k} {v}" for k, v in out["paired_outcomes"].items()) + "."
    labels: dict[str, dict[str, list[int]]] = {}
    for d in done:
        for group, rows in d["human_labels"].items():
            acc = labels.setdefault(group, {})
            for r, counts in rows.items():
                acc[r] = [a + b for a, b in zip(acc.get(r, [0] * 4), counts, strict=True)]
    out["human_labels"] = labels
    md += ["", "## The human's commands the network was fitted to, by where the fresh felt lay", ""]
    md += ["Cases of the repetitions' demonstrations and interventions (before mirroring);"]
    md += ["blank: toward or away from the side the fresh felt last lay on.", ""]
    md += table(
        ("source", "where", "cases", "forward", "toward the felt", "away from the felt"),
        [
            [group, r, c[0]] + [pct(x / c[0] if c[0] else None) for x in c[1:]]
            for group, rows in labels.items()
            if group != BRANCH_LABELS
            for r, c in rows.items()
        ],
    )
    if BRANCH_LABELS in labels:
        md += ["", "## On a blank map while the branch side gives a side", ""]
        md += ["The human's commands the network was fitted to (before mirroring):", ""]
        md += table(
            ("source", "cases", "forward", "toward the branch side", "away from it"),
            [
                [group, c[0]] + [pct(x / c[0] if c[0] else None) for x in c[1:]]
                for group, c in labels[BRANCH_LABELS].items()
            ],
        )
        md += ["", "Each driver's and its shadow's commands at those steps, by the loop's sharpest"]
        md += ["turn and the lap's outcome:", ""]
        rows = []
        for driver in ("learned", "rule"):
            t = step_table([x for x in laps if x["driver"] == driver])
            given = (t["amount"] <= 0.0) & (t["branch"] != 0.5)
            cases = {
                "all laps": given,
                "sharpest > 135°": given & (t["turn"] == TURN_BIN_LABELS[-1]),
            }
            cases |= {"failed laps": given & ~t["success"].astype(bool)}
            for case, m in cases.items():
                for who in ("learned", "rule"):
                    c, side = t[who][m], t["branch"][m]
                    toward, away = pivots(c, side > 0.5, side < 0.5)
                    n = int(m.sum())
                    rows.append(
                        [f"{driver} drives", case, who, n]
                        + [pct(float(v.mean()) if n else None) for v in (c == 0, toward, away)]
                    )
        out["branch_side_steps"] = rows
        md += table(("laps", "steps", "command of", "steps n", "forward", "toward", "away"), rows)
    for driver, title in (
        ("learned", "the learned policy drives, the rule shadows"),
        ("rule", "the rule drives, the learned policy shadows"),
    ):
        t = step_table([x for x in laps if x["driver"] == driver])
        rows = {k: parting(t, m) for k, m in regions(t).items()}
        blank = t["amount"] <= 0.0
        conf = {
            case: [[int(((t["learned"] == a) & (t["rule"] == b) & m).sum()) for b in range(3)]
                   for a in range(3)]
            for case, m in (("not blank", ~blank), ("blank", blank))
        }  # fmt: skip
        out["by_driver"][driver] = {"regions": rows, "confusion": conf}
        md += ["", f"## When {title}", ""]
        md += table(
            ("steps where", "steps", *COLUMNS),
            [[k, r["steps"]] + [pct(r[c]) for c in COLUMNS] for k, r in rows.items()],
        )
        md += ["", "Rows the learned command, columns the rule's; map not blank, then blank:", ""]
        md += table(
            ("learned \\ rule", "forward", "left", "right", "forward", "left", "right"),
            [[n] + conf["not blank"][i] + conf["blank"][i] for i, n in enumerate(NAMES)],
        )
        md += ["", f"In words ({title}):", ""]
        md += [
            f"* {k.replace('not blank, ', 'with the fresh felt ')} ({r['steps']} steps): the"
            f" learned policy pivots {pct(r['learned pivots'])}, the rule"
            f" {pct(r['rule pivots'])}; the learned drives forward where the rule pivots"
            f" {pct(r['learned forward, rule pivots'])}, pivots where the rule drives forward"
            f" {pct(r['learned pivots, rule forward'])}, the other way"
            f" {pct(r['opposite pivots'])}."
            for k, r in list(rows.items())[1:2] + list(rows.items())[3:7]
        ]
    stored = [
        {k: v for k, v in lap.items() if k not in ("inputs", "branch")}
        | {n: [round(1000 * float(x)) for x in lap["inputs"][:, i]] for i, n in enumerate(INPUTS)}
        | {"branch_in": [round(1000 * float(x)) for x in lap["branch"]]}
        for lap in laps
    ]  # the map's inputs per step, in thousandths
    return "\n".join(md) + "\n", out | {"laps": stored}


def main() -> None:
    global STUDY, CONDITION, STUDIED, RULE, SPLIT  # noqa: PLW0603 - the report reads them
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repetitions", type=int, default=4, help="first N of the seed's")
    parser.add_argument("--seed", type=int, default=0, help="the study's seed (default 0)")
    parser.add_argument(
        "--test-split",
        action="store_true",
        help="a frozen configuration's study on the test split: the rule beside it, no choice",
    )
    parser.add_argument("--loops", type=int, default=None, help="first K loops (default 10)")
    parser.add_argument("--out", type=Path, default=HERE / "results")
    parser.add_argument(
        "--study", type=Path, default=STUDY, help="the selection study whose condition to learn"
    )
    parser.add_argument("--condition", default=CONDITION, help="its condition (the learner)")
    args = parser.parse_args()
    name = "where_they_part"
    if (args.study.resolve(), args.condition) != (STUDY, CONDITION):
        name = f"where_they_part_{args.condition}"
        STUDY, CONDITION = args.study.resolve(), args.condition
        if args.test_split:
            name = f"where_they_part_{STUDY.stem}_{args.condition}_seed{args.seed}"
        stem = STUDY.stem
        STUDIED = STUDY.parent / "results" / stem / CONDITION / f"seed{args.seed}" / "results.json"
    study = load_study(STUDY)
    base = next(c for c in study.conditions if c.name == CONDITION).config
    if isinstance(base.memory, FreshFeltConfig):  # the rule reads the learner's own map
        RULE = dataclasses.replace(RULE, memory=base.memory)
    if args.seed not in study.seeds:
        parser.error(f"--seed {args.seed}: the study runs seeds {study.seeds}")
    config = dataclasses.replace(base, seed=args.seed, repetitions=study.repetitions)
    loops = args.loops or config.random_loops
    if config.random_split != "validation" and not args.test_split:
        parser.error(f"{STUDY.name} drives {config.random_split} loops: --test-split to score")
    SPLIT = config.random_split
    t0 = time.perf_counter()
    seeds = repetition_seeds(args.seed, study.repetitions)[: args.repetitions]
    done = [run_repetition(i, s, config, loops) for i, s in enumerate(seeds)]
    text, data = report(done, len(seeds), loops, time.perf_counter() - t0, args.seed)
    data["timing_s"] = {str(d["repetition"]): d["timing_s"] for d in done}
    args.out.mkdir(parents=True, exist_ok=True)
    atomic_write_text(args.out / f"{name}.md", text)
    atomic_write_text(args.out / f"{name}.json", json.dumps(data, separators=(",", ":")))
    print(text)


if __name__ == "__main__":
    main()
