"""Replay one repetition's runs step by step: what the controller saw, remembered and did.

Learns the repetition's controller exactly as the benchmark runner does (same seeds: the
repetition's demonstration, learning and trial seeds are spawned from the benchmark seed), then
drives the runs of one track and direction again with the same world seeds and prints, for every
run, its outcome and, for the failed ones, the last steps before the end: step, command, memory
inputs (if any) and pose. With the same settings as the benchmark or study job (``--test-tracks``
as its test tracks, in the same order: they decide the world seeds), the outcomes are the ones
in its ``results.json``; each run's line shows the outcome the relearned repetition recorded.

Run, e.g. for the clockwise testing-track laps of repetition 0 of ``goal_confirm_4``'s seed 0::

    .venv/bin/python benchmarks/experiments/goal_selection/round4/replay_laps.py --method hg-dagger --memory last_bend \\
        --turnarounds toward_last_bend --seed 0 --repetition 0 --track testing --direction cw
"""

from __future__ import annotations

import argparse
import tempfile
from typing import Any

import numpy as np

from lfd_track.benchmark.runner import (
    BenchmarkConfig,
    repetition_seeds,
    repetition_streams,
    run_repetition,
    run_trial,
    trial_worlds,
)
from lfd_track.demo.demonstrator import HumanConfig
from lfd_track.envs.track_env import LfDTrackEnv
from lfd_track.methods import method_names
from lfd_track.policy.controller import Controller
from lfd_track.policy.memory import MEMORY_KINDS, memory_config
from lfd_track.teaching.scripted import TURNAROUND_RULES

COMMAND_NAMES = ("F", "L", "R")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--method", choices=method_names(), default="paper")
    parser.add_argument("--preset", default="paper")
    parser.add_argument("--memory", choices=MEMORY_KINDS, default="none")
    parser.add_argument("--turnarounds", choices=TURNAROUND_RULES, default="alternate")
    parser.add_argument("--mirror", action="store_true")
    parser.add_argument("--seed", type=int, default=0, help="benchmark seed")
    parser.add_argument("--repetitions", type=int, default=10, help="of the benchmark run")
    parser.add_argument("--repetition", type=int, default=0, help="which one to replay")
    parser.add_argument("--track", default="testing", help="the track whose runs are replayed")
    parser.add_argument(
        "--test-tracks",
        nargs="+",
        default=None,
        help="the job's test tracks in its order (default: testing, then --track if another)",
    )
    parser.add_argument("--direction", default="cw", help="cw / ccw, or direction_1 / _2")
    parser.add_argument("--last", type=int, default=40, help="steps shown before a failure")
    args = parser.parse_args(argv)
    if not 0 <= args.repetition < args.repetitions:
        parser.error("--repetition must be in 0..repetitions-1")

    if args.test_tracks is not None:
        tracks = tuple(args.test_tracks)
    else:
        tracks = ("testing",) if args.track in ("training", "testing") else ("testing", args.track)
    config = BenchmarkConfig(
        repetitions=args.repetitions,
        seed=args.seed,
        preset=args.preset,
        method=args.method,
        human=HumanConfig(turnarounds=args.turnarounds),
        memory=memory_config({"kind": args.memory}),
        mirror=args.mirror,
        test_tracks=tracks,
    )
    seed = repetition_seeds(config.seed, config.repetitions)[args.repetition]
    with tempfile.TemporaryDirectory() as work:
        result = run_repetition(args.repetition, seed, config, work)
        controller = Controller.load(f"{work}/rep_{args.repetition:02d}/controller.json")
    recorded = [
        o for o in result.outcomes if (o.track, o.direction) == (args.track, args.direction)
    ]
    if not recorded:
        parser.error(f"no runs on {args.track} {args.direction} in this benchmark")

    _, _, trial_seed = repetition_streams(seed)
    for track, reverse, direction, env_seed in trial_worlds(trial_seed, config.test_tracks):
        if (track, direction) != (args.track, args.direction):
            continue
        env = LfDTrackEnv(track=track, reverse=reverse, preset=config.preset)
        for trial in range(config.trials_per_direction):
            log: list[tuple[Any, ...]] = []

            def keep(step: Any, log: list = log) -> None:
                pose = np.round(step.moment.info["pose"], 2).tolist()
                log.append((step.moment.step, COMMAND_NAMES[int(step.command)],
                            step.percept.memory.tolist(), pose))  # fmt: skip

            info, _, steps = run_trial(
                env, controller, seed=env_seed if trial == 0 else None, on_loop_step=keep
            )
            failure = info["failure"] or (None if info["success"] else "timeout")
            print(
                f"{track} {direction} run {trial}: {'success' if info['success'] else failure}"
                f" after {steps} steps; corners negotiated {info['corners_negotiated']}"
                f" (recorded: {'success' if recorded[trial].success else recorded[trial].failure})"
            )
            if not info["success"]:
                print("  step command memory pose (x, y, heading)")
                for entry in log[-args.last :]:
                    print("  ", *entry)
        env.close()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
