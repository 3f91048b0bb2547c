"""What limits generalization: the teacher's ceiling and the road values' ceiling.

Parts (see README.md beside this file for the protocol):

* ``teacher`` — the scripted human itself (privileged: pure pursuit on the known track) laps
  every shipped loop both ways and the training track both ways, with its default traits and
  with its reaction delay and lapses switched off.
* ``tune`` — the hand-written road-value rule (``lfd_track.teaching.handwritten``), reactive
  and latched, over a fixed grid, scored on the training track and the validation loop only.
* ``handwritten`` — the two rules the tuning chose, on every loop and the training track.
* ``tune-seen`` / ``seen`` — the same for the rule with the other one-bit latch (toward the side
  the felt was last seen on), over its own grid (``SEEN_GRID``), fixed before it ran.
* ``tune-fresh`` / ``fresh`` — the rule on the ``fresh_felt`` memory (a dead-reckoned map of the
  felt the rover has not driven along; ``lfd_track.teaching.handwritten.FreshFeltRule``), tuned
  on the training track and the validation loops ``kite``, ``cove`` and ``ledge`` over
  ``FRESH_GRID``, then scored on every loop (the two new unseen loops included).
* ``direct`` — the 40-5-3 network evolved by the paper's GA directly on progress along the
  training track (no human), then scored like the rules; robot time counted.
* ``online-evolution`` — (μ+1)-ONLINE: the same network evolved on board one robot that is never
  reset to the start (``lfd_track.learning.direct``), then scored the same way.

Every part drives the paper preset; the road library is the one a standard demonstration built
(the paper pipeline's seed 0, repetition 0), frozen. Results go to ``results/<part>.json`` and
``results/<part>.md``.

    .venv/bin/python benchmarks/experiments/limits/limits.py teacher --laps 30 --workers 2
"""

from __future__ import annotations

import argparse
import dataclasses
import itertools
import json
import math
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from lfd_track.benchmark.runner import repetition_seeds, repetition_streams, trial_worlds
from lfd_track.dataset import load_demonstration
from lfd_track.demo.demonstrator import run_demonstration
from lfd_track.envs.track_env import LfDTrackEnv
from lfd_track.learning.direct import (
    DirectConfig,
    MuPlusOneConfig,
    direct_evolution,
    mu_plus_one_online,
)
from lfd_track.policy.memory import FreshFeltConfig, MemoryConfig
from lfd_track.teaching.arbiter import Arbiter
from lfd_track.teaching.commanders import PolicyCommander
from lfd_track.teaching.handwritten import (
    FreshFeltRule,
    FreshFeltRuleConfig,
    RoadRule,
    RoadRuleConfig,
)
from lfd_track.teaching.loop import TeachingLoop
from lfd_track.teaching.perception import Perception
from lfd_track.teaching.scripted import HumanConfig, ScriptedHuman
from lfd_track.vision.road_library import RoadLibrary
from lfd_track.world.driver import CentrelineDriver

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "results"
LOOPS = ("testing", "kite", "sbend", "notch", "bolt", "step")
VALIDATION = "kite"
#: Part 2c: its validation loops (choosing only) and every loop it is scored on.
FRESH_VALIDATION = ("kite", "cove", "ledge")
NEW_LOOPS = ("arrow", "zed", "cove", "ledge")
FRESH_LOOPS = (*LOOPS, *NEW_LOOPS)
UNSEEN = ("notch", "bolt", "step", "arrow", "zed")
TRIAL_SEED = 20240601  # the worlds (floors, lighting) of every direction are drawn from this
TEACHERS = {
    "human": HumanConfig(),
    "noise-free": HumanConfig(reaction_delay_prob=0.0, lapse_prob=0.0),
}


def directions(loops: tuple[str, ...]) -> list[tuple[str, bool, str, int]]:
    """(track, reverse, direction, world seed) of the training track and each loop, both ways."""
    return trial_worlds(TRIAL_SEED, loops)


def standard_library() -> RoadLibrary:
    """The road library of the paper pipeline's seed 0, repetition 0 demonstration."""
    demo_seed, _, _ = repetition_streams(repetition_seeds(0, 10)[0])
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "demonstration.lfdemo"
        run_demonstration(path, seed=demo_seed, fsync=False)
        library = load_demonstration(path).metadata["road_library"]
    return RoadLibrary.from_dict(library)


def _outcome(info: dict[str, Any], steps: int) -> dict[str, Any]:
    failure = info["failure"]
    if not info["success"] and failure is None:
        failure = "timeout"
    return {
        "success": bool(info["success"]),
        "failure": failure,
        "failed_corner": info.get("failed_corner"),
        "corners_negotiated": list(info["corners_negotiated"]),
        "steps": steps,
    }


# ---------------------------------------------------------------------------------- teacher
def run_teacher(job: tuple[str, str, bool, str, int, int, int]) -> dict[str, Any]:
    """Laps of the scripted human (privileged) in one direction."""
    teacher, track, reverse, direction, world_seed, laps, human_seed = job
    env = LfDTrackEnv(track=track, reverse=reverse)
    driver = CentrelineDriver(env.track, TEACHERS[teacher].driver)
    rng = np.random.default_rng(human_seed)
    outcomes = []
    for lap in range(laps):
        frame, info = env.reset(seed=world_seed if lap == 0 else None)
        # The human steers by the privileged pose, not the picture: the camera frames are not
        # drawn (physics, sensor-independent streams and scoring are unchanged).
        env._renderer.render = lambda *args, **kwargs: frame  # noqa: B023, SLF001
        person = ScriptedHuman(TEACHERS[teacher], rng)
        steps = 0
        while True:
            command = person.decide(driver, np.asarray(info["pose"]), info["progress_m"])
            _, _, terminated, truncated, info = env.step(int(command))
            steps += 1
            if terminated or truncated:
                break
        outcomes.append(_outcome(info, steps))
    env.close()
    return {"policy": teacher, "track": track, "direction": direction, "outcomes": outcomes}


# ---------------------------------------------------------------------------------- road rule
_LIBRARY: RoadLibrary | None = None


def _library() -> RoadLibrary:
    global _LIBRARY
    if _LIBRARY is None:
        _LIBRARY = RoadLibrary.from_dict(json.loads((RESULTS / "library.json").read_text()))
    return _LIBRARY


def _rule_laps(job: tuple, make_rule, memory: MemoryConfig | None) -> dict[str, Any]:  # noqa: ANN001
    """Laps in one direction of the hand-written rule ``make_rule()`` builds afresh for each
    lap, reading ``memory`` (frozen standard library)."""
    name, _, track, reverse, direction, world_seed, laps = job
    env = LfDTrackEnv(track=track, reverse=reverse)
    outcomes = []
    for lap in range(laps):
        rule = make_rule()
        loop = TeachingLoop(
            env, Perception(_library(), "frozen", memory), Arbiter("policy"), policy=rule
        )
        loop.reset(seed=world_seed if lap == 0 else None)
        loop.run()
        record = _outcome(loop.info, loop.counts.steps)
        record["blank_frames"] = rule.blank_frames
        outcomes.append(record)
    env.close()
    return {"policy": name, "track": track, "direction": direction, "outcomes": outcomes}


def run_rule(job: tuple[str, dict, str, bool, str, int, int]) -> dict[str, Any]:
    """Laps of the hand-written rule ``config`` in one direction (frozen standard library)."""
    cfg = RoadRuleConfig(**job[1])
    return _rule_laps(job, lambda: RoadRule(cfg), cfg.memory)


def fresh_rule_config(config: dict[str, Any]) -> FreshFeltRuleConfig:
    """The fresh-felt rule of a grid point: ``turn_deg`` and the map's settings."""
    memory = {k: v for k, v in config.items() if k != "turn_deg"}
    return FreshFeltRuleConfig(
        turn_deg=config.get("turn_deg", 15.0), memory=FreshFeltConfig.plain(**memory)
    )


def run_fresh_rule(job: tuple[str, dict, str, bool, str, int, int]) -> dict[str, Any]:
    """Laps of the fresh-felt rule ``config`` in one direction (frozen standard library)."""
    cfg = fresh_rule_config(job[1])
    return _rule_laps(job, lambda: FreshFeltRule(cfg), cfg.memory)


def run_network(job: tuple[str, list[float], str, bool, str, int, int]) -> dict[str, Any]:
    """Laps of a 40-5-3 network ``weights`` in one direction (frozen standard library)."""
    name, weights, track, reverse, direction, world_seed, laps = job
    env = LfDTrackEnv(track=track, reverse=reverse)
    outcomes = []
    for lap in range(laps):
        loop = TeachingLoop(
            env,
            Perception(_library(), "frozen"),
            Arbiter("policy"),
            policy=PolicyCommander(np.asarray(weights, dtype=np.float64)),
        )
        loop.reset(seed=world_seed if lap == 0 else None)
        loop.run()
        outcomes.append(_outcome(loop.info, loop.counts.steps))
    env.close()
    return {"policy": name, "track": track, "direction": direction, "outcomes": outcomes}


# ---------------------------------------------------------------------------------- evolution
#: Robot-time budget of each evolution run [s] and the settings fixed before running (README).
EVOLUTION_BUDGET_S = 4_000.0
DIRECT = DirectConfig(population_size=10, generations=25, robot_budget_s=EVOLUTION_BUDGET_S)
ONLINE = MuPlusOneConfig(
    mu=10, tau=50, recovery=10, evaluations=100_000, robot_budget_s=EVOLUTION_BUDGET_S
)
#: The paper pipeline's human effort (seed 0, 10 repetitions), for the robot-time comparison.
PAPER_RESULTS = (
    HERE.parent / "beyond_the_paper/results/bilinear/beyond_the_paper/paper/seed0/results.json"
)


def paper_learning_drive_s() -> list[float]:
    """``learning_drive_s`` of each repetition of the paper pipeline (seed 0)."""
    effort = json.loads(PAPER_RESULTS.read_text())["human_effort"]["repetitions"]
    return [float(r["learning_drive_s"]) for r in effort]


def _curve_table(curve: list[dict[str, Any]], x: str, rows: int = 12) -> str:
    """Markdown: the learning curve at about ``rows`` evenly spaced points (and the last)."""
    picks = sorted({round(i * (len(curve) - 1) / (rows - 1)) for i in range(rows)})
    lines = [f"| {x} | robot s | best fitness [m] | mean fitness [m] |", "|---|---|---|---|"]
    for i in picks:
        p = curve[i]
        best = p.get("best_ever", p["best"])
        lines.append(f"| {p[x]} | {p['robot_s']:.0f} | {best:.2f} | {p['mean']:.2f} |")
    return "\n".join(lines)


def learn_evolution(part: str, seed: int) -> dict[str, Any]:
    """Evolve (``direct`` or ``online-evolution``); saves ``results/<name>.learning.json``."""
    t0 = time.perf_counter()

    def show(point: dict[str, Any]) -> None:
        print(json.dumps(point), file=sys.stderr, flush=True)

    if part == "direct":
        name, config = "direct", DIRECT
        result = direct_evolution(_library(), config, seed, progress=show)
        extra = {
            "generations": result.generations,
            "evaluations": result.evaluations,
            "world_seeds": result.world_seeds,
            "put_backs": 0,
        }
    else:
        name, config = "mu_plus_one", ONLINE
        result = mu_plus_one_online(_library(), config, seed, progress=show)
        extra = {
            "evaluations": result.evaluations,
            "children": result.children,
            "accepted": result.accepted,
            "reevaluations": result.reevaluations,
            "world_seed": result.world_seed,
            "put_backs": result.put_backs,
            "final_fitness": result.final_fitness,
        }
    paper_s = paper_learning_drive_s()
    learning = {
        "part": name,
        "seed": seed,
        "config": dataclasses.asdict(config),
        "effort": {
            "paper_pipeline_learning_drive_s": {
                "per_repetition": paper_s,
                "mean": round(sum(paper_s) / len(paper_s), 2),
            },
            "human_commands": 0,
            "corrections": 0,
            "put_backs": extra["put_backs"],
            "learning_drive_s": result.robot_s,
            "learning_steps": result.steps,
        },
        "best_fitness": result.best_fitness,
        "weights": [float(w) for w in result.best_weights],
        "curve": result.curve,
        "learn_wall_s": round(time.perf_counter() - t0, 1),
        **extra,
    }
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / f"{_stem(name, seed)}.learning.json").write_text(
        json.dumps(learning, indent=1) + "\n"
    )
    return learning


def _stem(name: str, seed: int) -> str:
    """Result file stem of an evolution run: seed 0 keeps the first run's names."""
    return name if seed == 0 else f"{name}.seed{seed}"


def score_evolution(
    part: str, seed: int, laps: int, workers: int, loops: tuple[str, ...] = LOOPS
) -> None:
    """Score the controller ``learn_evolution`` saved, by the protocol (``laps`` per direction);
    ``loops`` other than the protocol's go to ``<stem>.new_loops``."""
    name = "direct" if part == "direct" else "mu_plus_one"
    stem = _stem(name, seed)
    learning = json.loads((RESULTS / f"{stem}.learning.json").read_text())
    x = "generation" if name == "direct" else "evaluation"
    policy = f"{name} (seed {learning['seed']})"
    jobs = [(policy, learning["weights"], *d, laps) for d in directions(loops)]
    results = _run(run_network, jobs, workers)
    effort = learning["effort"]
    note = (
        f"{name}, seed {learning['seed']}: {effort['learning_drive_s']:.0f} s of robot time while "
        f"learning ({effort['learning_steps']} commands; the paper pipeline: "
        f"{effort['paper_pipeline_learning_drive_s']['mean']:.0f} s per repetition), 0 human "
        f"commands, 0 corrections, {effort['put_backs']} put-backs by hand; best fitness "
        f"{learning['best_fitness']:.2f} m. Scored {laps} laps per track and direction.\n\n"
        f"Learning curve (fitness: progress along the centreline, see the README):\n\n"
        + _curve_table(learning["curve"], x)
    )
    body = {k: v for k, v in learning.items() if k != "part"}
    _write(stem if loops == LOOPS else f"{stem}.new_loops", results, note, {**body, "laps": laps})


# ---------------------------------------------------------------------------------- tables
def wilson(k: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """95 % Wilson interval of k successes in n."""
    if n == 0:
        return (0.0, 0.0)
    p = k / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return (max(0.0, centre - half), min(1.0, centre + half))


def table(results: list[dict[str, Any]], note: str) -> str:
    """Markdown: laps per policy and direction, with failures by kind and corner."""
    policies = list(dict.fromkeys(r["policy"] for r in results))
    lines = [note, ""]
    for policy in policies:
        rows = [r for r in results if r["policy"] == policy]
        lines += [
            f"### {policy}",
            "",
            "| track | direction | laps | failures (kind: corner) |",
            "|---|---|---|---|",
        ]
        unseen_k = unseen_n = all_k = all_n = 0
        for r in rows:
            k = sum(o["success"] for o in r["outcomes"])
            n = len(r["outcomes"])
            if r["track"] in ("notch", "bolt", "step"):
                unseen_k, unseen_n = unseen_k + k, unseen_n + n
            if r["track"] in UNSEEN:
                all_k, all_n = all_k + k, all_n + n
            fails: dict[str, int] = {}
            for o in r["outcomes"]:
                if not o["success"]:
                    key = f"{o['failure']}: {o['failed_corner']}"
                    fails[key] = fails.get(key, 0) + 1
            text = ", ".join(f"{key} ×{v}" for key, v in sorted(fails.items())) or "–"
            lines.append(f"| {r['track']} | {r['direction']} | {k}/{n} | {text} |")
        lo, hi = wilson(unseen_k, unseen_n)
        lines += [
            "",
            f"Unseen loops notch/bolt/step: {unseen_k}/{unseen_n} = "
            f"{100 * unseen_k / max(unseen_n, 1):.0f} % [{100 * lo:.0f}–{100 * hi:.0f}].",
            "",
        ]
        if all_n > unseen_n:  # the newer unseen loops arrow and zed were driven too
            lo, hi = wilson(all_k, all_n)
            lines += [
                f"All unseen loops {'/'.join(UNSEEN)}: {all_k}/{all_n} = "
                f"{100 * all_k / all_n:.0f} % [{100 * lo:.0f}–{100 * hi:.0f}].",
                "",
            ]
    return "\n".join(lines)


def _run(fn, jobs: list, workers: int) -> list[dict[str, Any]]:
    if workers == 1:
        return [fn(j) for j in jobs]
    with ProcessPoolExecutor(max_workers=workers) as pool:
        return list(pool.map(fn, jobs))


def _write(name: str, results: list[dict[str, Any]], note: str, extra: dict | None = None) -> None:
    RESULTS.mkdir(exist_ok=True)
    payload = {"part": name, **(extra or {}), "results": results}
    (RESULTS / f"{name}.json").write_text(json.dumps(payload, indent=1) + "\n")
    (RESULTS / f"{name}.md").write_text(table(results, note) + "\n")


# ---------------------------------------------------------------------------------- tuning
#: The tuning grid, fixed before running (README): every combination, reactive and latched.
GRID = {
    "turn_at": (0.5, 1.0, 1.5),
    "row_weights": ((1.0, 1.0, 1.0, 1.0, 1.0), (3.0, 2.0, 1.0, 1.0, 1.0)),
}


def candidates() -> list[tuple[str, dict]]:
    out = []
    for latch in (False, True):
        for turn_at, rows in itertools.product(*GRID.values()):
            cfg = {"turn_at": turn_at, "row_weights": rows, "latch": latch}
            far = "far" if rows[0] > 1 else "flat"
            name = f"{'latch' if latch else 'reactive'}.t{turn_at}.{far}"
            out.append((name, cfg))
    return out


#: The grid of the last-seen latch (README, part 2b), fixed before it ran: the first grid's best
#: turn_at (1.5) was its edge, so this one is centred on it.
SEEN_GRID = {
    "turn_at": (1.0, 1.5, 2.0),
    "row_weights": ((1.0, 1.0, 1.0, 1.0, 1.0), (3.0, 2.0, 1.0, 1.0, 1.0)),
}


def seen_candidates() -> list[tuple[str, dict]]:
    out = []
    for turn_at, rows in itertools.product(*SEEN_GRID.values()):
        far = "far" if rows[0] > 1 else "flat"
        out.append(
            (
                f"seen.t{turn_at}.{far}",
                {"turn_at": turn_at, "row_weights": rows, "seen_latch": True},
            )
        )
    return out


#: The grid of the fresh-felt rule (README, part 2c), fixed before it ran.
FRESH_GRID = {
    "path_radius_m": (0.3, 0.35, 0.4),
    "reach_m": (0.6, 0.8, 1.0, 1.2),
    "turn_deg": (10.0, 15.0, 20.0),
}


def fresh_candidates() -> list[tuple[str, dict]]:
    return [
        (f"fresh.r{r}.reach{reach}.t{t:g}", {"path_radius_m": r, "reach_m": reach, "turn_deg": t})
        for r, reach, t in itertools.product(*FRESH_GRID.values())
    ]


def tune(
    part: str,
    grid: list[tuple[str, dict]],
    kinds: tuple[str, ...],
    laps: int,
    workers: int,
    validation: tuple[str, ...] = (VALIDATION,),
    run=None,  # noqa: ANN001 - the job function (default: the road rule)
) -> None:
    """Score every candidate on the training track and the validation loops; the most laps wins
    (ties: the first in grid order), for each kind (the name's first dotted part)."""
    dirs = directions(validation)
    jobs = [(name, cfg, *d, laps) for name, cfg in grid for d in dirs]
    results = _run(run or run_rule, jobs, workers)
    score: dict[str, int] = {}
    for r in results:
        score[r["policy"]] = score.get(r["policy"], 0) + sum(o["success"] for o in r["outcomes"])
    chosen = {}
    for kind in kinds:
        names = [n for n, _ in grid if n.startswith(kind + ".")]
        best = max(names, key=lambda n: score[n])  # ties: the first in grid order
        chosen[kind] = {"name": best, "config": dict(grid)[best], "laps": score[best]}
    loops = ", ".join(f"`{v}`" for v in validation)
    note = (
        f"Tuning on the training track and {loops} only, {laps} laps per "
        f"direction; chosen: {json.dumps(chosen)}"
    )
    _write(part, results, note, {"score": score, "chosen": chosen})


def score_rules(
    part: str,
    chosen: dict[str, dict],
    laps: int,
    workers: int,
    how: str,
    loops: tuple[str, ...] = LOOPS,
    run=None,  # noqa: ANN001 - the job function (default: the road rule)
) -> None:
    """The chosen rules on every loop and the training track."""
    jobs = [
        (f"{kind} ({c['name']})", c["config"], *d, laps)
        for kind, c in chosen.items()
        for d in directions(loops)
    ]
    results = _run(run or run_rule, jobs, workers)
    note = (
        f"The hand-written road-value rules ({how}), {laps} laps per track "
        "and direction; no learning (human commands, corrections, robot seconds while "
        "learning: none beyond the standard demonstration that built the library)."
    )
    _write(part, results, note, {"chosen": chosen})


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "part",
        choices=(
            "library",
            "teacher",
            "teacher-new-loops",
            "tune",
            "handwritten",
            "tune-seen",
            "seen",
            "tune-fresh",
            "fresh",
            "rules-new-loops",
            "direct",
            "online-evolution",
        ),
    )
    parser.add_argument("--seed", type=int, default=0, help="direct, online-evolution: run seed")
    parser.add_argument(
        "--learn-only", action="store_true", help="direct, online-evolution: evolve, do not score"
    )
    parser.add_argument(
        "--score-only",
        action="store_true",
        help="direct, online-evolution: score the controller an earlier run evolved",
    )
    parser.add_argument("--laps", type=int, default=30, help="laps per track and direction")
    parser.add_argument(
        "--new-loops",
        action="store_true",
        help="direct, online-evolution --score-only: score on the loops added later instead",
    )
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument(
        "--fixed", action="store_true", help="handwritten: the default rule settings, untuned"
    )
    args = parser.parse_args(argv)
    t0 = time.perf_counter()
    if args.part == "library":
        RESULTS.mkdir(exist_ok=True)
        (RESULTS / "library.json").write_text(json.dumps(standard_library().to_dict()) + "\n")
    elif args.part in ("teacher", "teacher-new-loops"):
        # The loops added after part 1 ran get their own results (part 1's stay as they were).
        loops = LOOPS if args.part == "teacher" else NEW_LOOPS
        jobs = [
            (teacher, track, rev, d, seed, args.laps, 1000 + i)
            for teacher in TEACHERS
            for i, (track, rev, d, seed) in enumerate(directions(loops))
        ]
        results = _run(run_teacher, jobs, args.workers)
        note = (
            f"The scripted human (privileged), {args.laps} laps per track and direction; no "
            "learning (human commands, corrections, robot seconds while learning: none)."
        )
        _write(
            args.part.replace("-", "_"),
            results,
            note,
            {"teachers": {k: dataclasses.asdict(v) for k, v in TEACHERS.items()}},
        )
    elif args.part in ("direct", "online-evolution"):
        if not args.score_only:
            learn_evolution(args.part, args.seed)
        if not args.learn_only:
            loops = NEW_LOOPS if args.new_loops else LOOPS
            score_evolution(args.part, args.seed, args.laps, args.workers, loops)
    elif args.part == "tune":
        tune("tune", candidates(), ("reactive", "latch"), args.laps, args.workers)
    elif args.part == "tune-seen":
        tune("tune_seen", seen_candidates(), ("seen",), args.laps, args.workers)
    elif args.part == "tune-fresh":
        tune(
            "tune_fresh",
            fresh_candidates(),
            ("fresh",),
            args.laps,
            args.workers,
            FRESH_VALIDATION,
            run_fresh_rule,
        )
    elif args.part == "fresh":
        chosen = json.loads((RESULTS / "tune_fresh.json").read_text())["chosen"]
        score_rules(
            "fresh",
            chosen,
            args.laps,
            args.workers,
            "the fresh-felt map rule, chosen by `tune-fresh`",
            FRESH_LOOPS,
            run_fresh_rule,
        )
    elif args.part == "rules-new-loops":
        # Parts 2 and 2b's chosen rules on the loops added after they ran.
        chosen = {
            **json.loads((RESULTS / "tune.json").read_text())["chosen"],
            **json.loads((RESULTS / "tune_seen.json").read_text())["chosen"],
        }
        score_rules(
            "rules_new_loops", chosen, args.laps, args.workers, "parts 2 and 2b's", NEW_LOOPS
        )
    elif args.part == "seen":
        chosen = json.loads((RESULTS / "tune_seen.json").read_text())["chosen"]
        score_rules("seen", chosen, args.laps, args.workers, "chosen by `tune-seen`")
    else:
        if args.fixed:  # the rule's settings as written before any run, not tuned
            chosen = {
                kind: {"name": "fixed", "config": {"latch": kind == "latch"}}
                for kind in ("reactive", "latch")
            }
        else:
            chosen = json.loads((RESULTS / "tune.json").read_text())["chosen"]
        how = "fixed before running" if args.fixed else "chosen by `tune`"
        score_rules("handwritten", chosen, args.laps, args.workers, how)
    print(f"{args.part}: {time.perf_counter() - t0:.0f} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
