"""Where the goal's decision time goes, frame by frame, and what cheaper image registrations of
the measured motion would leave: a measurement of which part binds the 5 ms budget.

Round 27's winner of the human-taught goal, the goal's configuration when this was measured
(``benchmarks/experiments/goal/chosen_round27.toml``, then named ``chosen.toml``; condition
``paper``; the map moved by the camera's measured motion, ``lfd_track/policy/odometry.py``, and
each driving session's colour balanced) is learned as ``bench_budget.py`` learns it (study seed 0, repetition
0), then drives the testing track each way once. Its frames are recorded and replayed, on one
thread, through a fresh perception and commander in rounds, interleaving:

* ``shipped`` — the configuration as it is; its replayed commands are checked against the drive's;
* registration variants — fewer starts of the coarse ECC fit (``2 starts``: 0 and -4 deg around
  the nominal turn; ``1 start``: the nominal turn only) and fewer ECC iterations per fit
  (``5 starts, 10 it``; ``1 start, 15 it``). These change what the map measures, so their
  commands differ from the recorded drive: they time the same frames, not a drive of their own,
  and nothing here says how they would lap.

Per frame: the whole decision (process CPU time, as ``bench_budget.py`` times it) and, inside
it, the map's motion step (``FreshFeltMemory.arrive``: the floor view and the registration).
Also for ``shipped``: the frames by how many ECC fits they ran.

Run: ``.venv/bin/python benchmarks/speed/bench_decision_tail.py [--rounds 4]`` — prints a table
and writes ``benchmarks/speed/results/decision_tail.json``.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from bench_budget import first_repetition_config, percentiles, repetition_zero, start_episode
from single_thread import load_average, pin_one_thread, run_facts

import lfd_track.policy.odometry as odometry
from lfd_track.benchmark.runner import learn_repetition
from lfd_track.policy.map_geometry import MapGeometry
from lfd_track.policy.memory import FreshFeltMemory
from lfd_track.utils.atomic import atomic_write_text

REPO = Path(__file__).resolve().parents[2]
STUDY = REPO / "benchmarks" / "experiments" / "goal" / "chosen_round27.toml"
RESULTS = Path(__file__).resolve().parent / "results" / "decision_tail.json"
SHIPPED = (odometry.COARSE_TURNS_DEG, odometry.ECC_ITERATIONS)
VARIANTS = {
    "shipped": SHIPPED,
    "2 starts": ((0.0, -4.0), SHIPPED[1]),
    "1 start": ((0.0,), SHIPPED[1]),
    "5 starts, 10 it": (SHIPPED[0], 10),
    "1 start, 15 it": ((0.0,), 15),  # the map's registration = "quick"
}
WARM_UP = 5  # first decisions of each replay left out (first calls allocate)


def learned_controller() -> tuple[Any, Any, int]:
    """The goal's ``paper`` controller of study seed 0, repetition 0, its world and trial seed."""
    config = first_repetition_config(STUDY, "paper")
    demo_seed, ga_seed, trial_seed, preset, extra = repetition_zero(config)
    with tempfile.TemporaryDirectory() as tmp:
        learned = learn_repetition(
            config, Path(tmp), demo_seed=demo_seed, ga_seed=ga_seed, preset=preset, **extra
        )
    return learned.controller, preset, trial_seed


def recorded_drive(controller: Any, preset: Any, seed: int) -> list[tuple[Any, list, list]]:
    """The testing track each way: per episode its base preset, frames (with the safe box flag)
    and commands."""
    rng = np.random.default_rng(seed)
    episodes = []
    for reverse in (False, True):
        env, perception, commander, frame, info = start_episode(controller, preset, reverse, rng)
        frames, commands, done = [], [], False
        while not done:
            frames.append((frame.copy(), info.get("safe_box_on_felt")))
            command = commander.act_on_values(perception.perceive(*frames[-1]).inputs)
            perception.note(command)
            commands.append(int(command))
            frame, _, terminated, truncated, info = env.step(int(command))
            done = terminated or truncated
        episodes.append((env.base_preset, frames, commands))
        env.close()
    return episodes


def replay(controller: Any, episodes: list) -> dict[str, np.ndarray]:
    """Per frame: decision ms, the motion step's ms, ECC fits run; and the commands."""
    fits, arrive_ms = [0], [0.0]
    ecc, arrive = cv2.findTransformECC, FreshFeltMemory.arrive

    def counted(*args: Any, **kwargs: Any) -> Any:
        fits[0] += 1
        return ecc(*args, **kwargs)

    def timed(self: Any, frame: np.ndarray) -> Any:
        t0 = time.process_time_ns()
        out = arrive(self, frame)
        arrive_ms[0] = (time.process_time_ns() - t0) / 1e6
        return out

    cv2.findTransformECC = counted  # every ECC fit the registration runs
    FreshFeltMemory.arrive = timed  # type: ignore[method-assign]
    rows: list[tuple[float, float, int, int]] = []
    try:
        for base, frames, _ in episodes:
            perception = controller.perception(
                "frozen", world_geometry=MapGeometry.from_preset(base)
            )
            commander = controller.commander()
            perception.start_episode()
            commander.reset()
            for i, (frame, box) in enumerate(frames):
                fits[0], arrive_ms[0] = 0, 0.0
                t0 = time.process_time_ns()
                command = commander.act_on_values(perception.perceive(frame, box).inputs)
                perception.note(command)
                spent = (time.process_time_ns() - t0) / 1e6
                if i >= WARM_UP:
                    rows.append((spent, arrive_ms[0], fits[0], int(command)))
    finally:
        cv2.findTransformECC, FreshFeltMemory.arrive = ecc, arrive  # type: ignore[method-assign]
    data = np.array(rows)
    return {"ms": data[:, 0], "arrive_ms": data[:, 1], "fits": data[:, 2], "commands": data[:, 3]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=4, help="replays of each variant")
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args()
    pin_one_thread()
    before = load_average()
    controller, preset, seed = learned_controller()
    episodes = recorded_drive(controller, preset, seed)
    recorded = np.concatenate([np.asarray(c[WARM_UP:]) for _, _, c in episodes])
    runs: dict[str, list[dict[str, np.ndarray]]] = {name: [] for name in VARIANTS}
    for _ in range(args.rounds):
        for name, (turns, iterations) in VARIANTS.items():
            # the controller's map searches with the "full" registration: replaced for a variant
            odometry.REGISTRATIONS["full"] = odometry.Registration(turns, iterations)
            try:
                runs[name].append(replay(controller, episodes))
            finally:
                odometry.REGISTRATIONS["full"] = odometry.Registration(*SHIPPED)
    for run in runs["shipped"]:  # the shipped replay decides as the drive did
        assert np.array_equal(run["commands"], recorded)
    table: dict[str, Any] = {}
    print(f"{'variant':<18} {'decision ms median / p95 / max':>32} {'motion step ms':>28}")
    for name, done in runs.items():
        ms = np.concatenate([r["ms"] for r in done])
        step = np.concatenate([r["arrive_ms"] for r in done])
        table[name] = {"decision": percentiles(ms), "motion_step": percentiles(step)}
        d, s = table[name]["decision"], table[name]["motion_step"]
        print(
            f"{name:<18} {d['median_ms']:>10.2f} / {d['p95_ms']:.2f} / {d['max_ms']:.2f}"
            f" {s['median_ms']:>12.2f} / {s['p95_ms']:.2f} / {s['max_ms']:.2f}"
        )
    shipped = runs["shipped"]
    ms, fits = (np.concatenate([r[k] for r in shipped]) for k in ("ms", "fits"))
    by_fits = {
        str(int(k)): {"frames": int((fits == k).sum()), **percentiles(ms[fits == k])}
        for k in np.unique(fits)
    }
    print(
        "shipped, frames by ECC fits:",
        {k: (v["frames"], v["median_ms"]) for k, v in by_fits.items()},
    )
    after = load_average()
    print(f"load average (1, 5, 15 min): before {before}, after {after}")
    result = {
        "benchmark": "decision_tail",
        "configuration": f"paper of {STUDY.relative_to(REPO)}, study seed 0, repetition 0",
        "frames_per_replay": int(len(recorded)),
        "rounds": args.rounds,
        "variants": {
            k: {"coarse_turns_deg": list(t), "iterations": i} for k, (t, i) in VARIANTS.items()
        },
        "caveat": "variants other than shipped time the recorded frames, not a drive of their own",
        "times": table,
        "shipped_by_ecc_fits": by_fits,
        **run_facts(before),
    }
    atomic_write_text(args.out, json.dumps(result, indent=2) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
