"""``lfd-track benchmark``: the paper protocol (Tables 2 and 3), repeated; its output folder
changes only when the whole run has succeeded (:mod:`lfd_track.utils.staging`)."""

from __future__ import annotations

import argparse
import os
import signal
import sys
import time
from pathlib import Path
from typing import Any

from ..benchmark import runner
from ..benchmark.config import MAX_RANDOM_LOOPS, ROOMS
from ..demo.demonstrator import HumanConfig
from ..learning.bc import MAX_WATCHED_FITS, BCConfig
from ..learning.extra_cases import load_cases
from ..methods import get_method, method_names, methods
from ..policy.features import DEFAULT_FEATURES, FEATURE_SETS
from ..policy.memory import MEMORY_KINDS
from ..policy.mlp import MAX_HIDDEN, MAX_MEMBERS, N_HIDDEN
from ..teaching.scripted import STEERING, TURNAROUND_RULES
from ..utils.outputs import refuse_undecodable, refuse_unsafe_output, shown_path
from ..utils.signals import Terminated, interrupted_exit_code, raise_terminated
from ..utils.staging import staged_output
from ..world.loops import SPLITS
from .types import (
    EXIT_OK,
    EXIT_USAGE,
    add_map_arguments,
    memory_from_args,
    unit_interval,
    whole_number_in,
)


def _cores() -> int:
    """CPU cores this process may use (the default number of benchmark workers)."""
    try:
        return max(len(os.sched_getaffinity(0)), 1)
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add ``benchmark`` to the ``lfd-track`` commands."""
    bench = subparsers.add_parser(
        "benchmark",
        help="reproduce the paper's Tables 2 and 3",
        description="The paper protocol: per repetition a fresh demonstration, evolution, then 3 runs each way on the training track and 3 laps each way on the testing track.",
    )
    bench.add_argument(
        "--repetitions",
        type=whole_number_in(1, runner.MAX_REPETITIONS),
        default=None,
        help=f"repetitions, at most {runner.MAX_REPETITIONS} (default: 10; 1 with --quick)",
    )
    bench.add_argument(
        "--trials",
        type=whole_number_in(1, runner.MAX_TRIALS_PER_DIRECTION),
        default=None,
        help=f"runs per direction per repetition, at most {runner.MAX_TRIALS_PER_DIRECTION}"
        " (default: 3; 1 with --quick)",
    )
    bench.add_argument(
        "--seed",
        type=whole_number_in(0, runner.MAX_SEED),
        default=0,
        help=f"benchmark seed, 0..{runner.MAX_SEED} (default: 0)",
    )
    bench.add_argument(
        "--workers",
        type=whole_number_in(1, runner.MAX_WORKERS),
        default=None,
        help=f"parallel processes, at most {runner.MAX_WORKERS}; results do not depend on it"
        f" (default: the number of cores, here {_cores()})",
    )
    bench.add_argument(
        "--preset", default="paper", help="environment preset name or TOML path (default: paper)"
    )
    bench.add_argument(
        "--room",
        choices=ROOMS,
        default="per_episode",
        help="when a preset with [randomization] draws its world: per_episode (a new room every"
        " episode) or per_repetition (one room per repetition, kept for teaching and driving);"
        " a preset without randomization has one world either way (default: per_episode)",
    )
    bench.add_argument(
        "--test-track",
        action="append",
        default=[],
        metavar="TRACK",
        help="also lap this loop (name or .toml path) both ways, as many laps as on the testing"
        " track; repeatable; results per track in results.json",
    )
    bench.add_argument(
        "--random-loops",
        type=whole_number_in(0, MAX_RANDOM_LOOPS),
        default=0,
        metavar="N",
        help="also lap N procedural loops per repetition, each drawn by the repetition (admitted"
        " once the scripted human laps it both ways) and lapped once each way; pooled by"
        " sharpest turn and strip width in results.json (default: 0)",
    )
    bench.add_argument(
        "--random-split",
        choices=SPLITS,
        default="validation",
        help="the split --random-loops draws from: train or validation to choose settings on,"
        " test to score a frozen configuration once (default: validation)",
    )
    bench.add_argument(
        "--demo-track",
        default="training",
        metavar="TRACK",
        help="open track (name or .toml path) the human demonstrates on, and HG-DAgger's rounds"
        " drive (default: the paper's training track, which is also scored either way)",
    )
    bench.add_argument(
        "--extra-cases",
        default="",
        metavar="PATH",
        help="saved cases (a .npz or a folder of them) the offline learners fit after each"
        " repetition's own demonstration's (default: none)",
    )
    described = (f"{m.name} ({m.summary})" if m.summary else m.name for m in methods())
    bench.add_argument(
        "--method",
        choices=method_names(),
        default="paper",
        help=f"how each repetition learns: {', '.join(described)} (default: paper)",
    )
    for method in methods():  # a method's own flags
        if method.flags is not None:
            method.flags.add(bench)
    bench.add_argument(
        "--turnarounds",
        choices=TURNAROUND_RULES,
        default="alternate",
        help="the human's turn-arounds at the training track's ends: alternate (the paper's),"
        " one_sided, unrecorded, toward_last_bend (default: alternate)",
    )
    bench.add_argument(
        "--memory",
        choices=MEMORY_KINDS,
        default="none",
        help="memory inputs of the policy after the 40 road values: none (the paper's),"
        " last_bend (the side of the last bend; pair it with --turnarounds toward_last_bend)"
        ", previous_command (the command executed the step before) or fresh_felt (a"
        " dead-reckoned map of the felt not yet driven along: its bearing, amount, distance)",
    )
    add_map_arguments(bench)
    bench.add_argument(
        "--steers-by",
        choices=STEERING,
        default="centreline",
        help="what the scripted human steers by: centreline (the track seen from above, default)"
        " or picture (the fresh-felt rule on the policy's map: needs --memory fresh_felt)",
    )
    bench.add_argument(
        "--features",
        choices=FEATURE_SETS,
        default=DEFAULT_FEATURES,
        help="per-region inputs of the policy: road_values (the paper's 40),"
        " road_values+colour (also each region's mean hue and saturation: 160), near_felt"
        " (where the felt lies across the picture's nearest rows, and how much: 2) or none (its"
        " memory inputs alone; needs a memory)",
    )
    bench.add_argument(
        "--mirror",
        action="store_true",
        help="learn from the cases and their mirror images (left and right swapped)",
    )
    bench.add_argument(
        "--policy-kind",
        choices=("mlp-sigmoid", "elman-sigmoid"),
        default="mlp-sigmoid",
        help="the network: the paper's MLP, or an Elman network (its hidden activations fed back;"
        " trained by the GA with --method paper, by backprop through time with --method bc)",
    )
    bench.add_argument(
        "--bc-bias",
        action="store_true",
        help="backprop's networks have biases (the bc settings: --method bc, and --online-learner,"
        " --hg-dagger-learner or --dagger-learner bc; default: none, the paper's network)",
    )
    bench.add_argument(
        "--bc-class-balance",
        type=unit_interval,
        default=None,
        metavar="K",
        help="backprop's case weights n_e ** -K, n_e the cases of the case's command (the bc"
        " settings, as --bc-bias; default 1: each command the same, 0: each case the same)",
    )
    bench.add_argument(
        "--bc-ensemble",
        type=whole_number_in(1, MAX_MEMBERS),
        default=None,
        metavar="K",
        help="backprop fits K networks from their own starting weights and drives by the mean of"
        f" their outputs (the bc settings, as --bc-bias; default 1: one network; at most"
        f" {MAX_MEMBERS})",
    )
    bench.add_argument(
        "--bc-watched-fits",
        type=whole_number_in(1, MAX_WATCHED_FITS),
        default=None,
        metavar="K",
        help="with --method bc: the learned policy drives the demonstration track twice each"
        " way; while it does not lap every lap, backprop fits again from new starting weights,"
        f" up to K fits, keeping the one that lapped most (default 1: not watched; at most"
        f" {MAX_WATCHED_FITS})",
    )
    bench.add_argument(
        "--bc-hidden",
        type=whole_number_in(1, MAX_HIDDEN),
        default=None,
        metavar="N",
        help="backprop's networks have N hidden nodes (the bc settings, as --bc-bias; default 5,"
        f" the paper's; at most {MAX_HIDDEN}; with --method dagger its own --hidden)",
    )
    bench.add_argument(
        "--shifted-views",
        action="store_true",
        help="learn also from each case's views from a step behind and a pivot either way,"
        " labelled with the command back (methods"
        f" {', '.join(m.name for m in methods() if m.takes_views)})",
    )
    bench.add_argument(
        "--careless",
        action="store_true",
        help="demonstrator keeps learning while the safe box is off the felt",
    )
    bench.add_argument(
        "--keep-learning",
        action="store_true",
        help="road library keeps learning during autonomous runs (default: frozen, as in the paper)",
    )
    bench.add_argument(
        "--quick", action="store_true", help="one repetition, one run per direction (a smoke test)"
    )
    bench.add_argument(
        "--out", required=True, help="output folder (results.json, report.md, plots)"
    )
    bench.set_defaults(func=run)
    return bench


def fits_by_backprop(config: runner.BenchmarkConfig) -> bool:
    """Whether ``config``'s method fits a network by backprop (its ``bc`` settings are used)."""
    if config.method == "bc":
        return True
    table = {"online": config.online, "hg-dagger": config.hg_dagger, "dagger": config.dagger}
    return getattr(table.get(config.method), "learner", None) == "bc"


def run(args: argparse.Namespace) -> int:
    """The ``benchmark`` command."""
    # Lazy: the drawing and progress-bar stack (OpenCV, tqdm) loads only when the command runs.
    from ..benchmark import report
    from ..utils.progress import progress_bar

    for other in methods():  # a method's own flags go with that method only
        given = [] if other.flags is None or other.name == args.method else other.flags.given(args)
        if given:
            print(f"lfd-track benchmark: {given[0]} needs --method {other.name}", file=sys.stderr)
            return EXIT_USAGE
    repetitions = 1 if args.quick and args.repetitions is None else (args.repetitions or 10)
    trials = args.trials or (1 if args.quick else 3)
    # --bc-bias, --bc-class-balance, --bc-ensemble, --bc-watched-fits, --bc-hidden: the backprop
    # settings (a table of BenchmarkConfig, by name).
    balance = 1.0 if args.bc_class_balance is None else args.bc_class_balance
    ensemble = 1 if args.bc_ensemble is None else args.bc_ensemble
    watched = 1 if args.bc_watched_fits is None else args.bc_watched_fits
    hidden = N_HIDDEN if args.bc_hidden is None else args.bc_hidden
    backprop_given = {
        "--bc-bias": args.bc_bias,
        "--bc-class-balance": args.bc_class_balance is not None,
        "--bc-ensemble": args.bc_ensemble is not None,
        "--bc-watched-fits": args.bc_watched_fits is not None,
        "--bc-hidden": args.bc_hidden is not None,
    }
    backprop_flags = any(backprop_given.values())
    backprop: dict[str, Any] = (
        {
            "bc": BCConfig(
                bias=args.bc_bias,
                class_balance=balance,
                ensemble=ensemble,
                watched_fits=watched,
                hidden=hidden,
            )
        }
        if backprop_flags
        else {}
    )
    try:  # settings that do not go together (e.g. --steers-by picture without the map) refused
        method = get_method(args.method)
        tables = {} if method.flags is None else {method.table: method.flags.settings(args)}
        config = runner.BenchmarkConfig(
            repetitions=repetitions,
            seed=args.seed,
            trials_per_direction=trials,
            preset=args.preset,
            human=HumanConfig(
                careful=not args.careless, turnarounds=args.turnarounds, steers_by=args.steers_by
            ),
            keep_learning=args.keep_learning,
            method=args.method,
            test_tracks=("testing", *args.test_track),
            random_loops=args.random_loops,
            random_split=args.random_split,
            room=args.room,
            memory=memory_from_args(args),
            mirror=args.mirror,
            shifted_views=args.shifted_views,
            policy_kind=args.policy_kind,
            demo_track=args.demo_track,
            extra_cases=args.extra_cases,
            features=args.features,
            **backprop,
            **runner.settings_arguments(tables),
        )
    except ValueError as exc:
        print(f"lfd-track benchmark: {exc}", file=sys.stderr)
        return EXIT_USAGE
    if backprop_flags and not fits_by_backprop(config):
        flag = next(name for name, on in backprop_given.items() if on)
        print(
            f"lfd-track benchmark: {flag} is for learners that use backprop (--method bc, or"
            f" --online-learner, --hg-dagger-learner or --dagger-learner bc), not {args.method}",
            file=sys.stderr,
        )
        return EXIT_USAGE
    # Track and preset names are recorded in results.json and report.md, which hold text only.
    for what, name in (
        ("preset", args.preset),
        ("demonstration track", args.demo_track),
        *(("test track", track) for track in args.test_track),
    ):
        refuse_undecodable(name, what)
    refuse_unsafe_output(args.out, folder=True)
    workers = args.workers or min(_cores(), runner.MAX_WORKERS)
    runner.check_workers(workers)
    # A bad preset, a track that is not a loop with corners or whose ground texture would be too
    # big with this preset fails here, before anything is created.
    runner.check_tracks(config)
    if config.extra_cases:
        load_cases(config.extra_cases)  # a bad file fails here, naming it
    out = Path(args.out)
    # The run goes to a staging folder and replaces the previous output only once it has
    # succeeded: a failure at any point leaves the previous output as it was. SIGTERM stops it
    # like Ctrl-C, so the staging folder is removed too.
    previous = signal.signal(signal.SIGTERM, raise_terminated)
    try:
        with staged_output(out) as stage:
            start = time.perf_counter()
            with progress_bar(
                config.repetitions, "benchmark", unit=" repetitions", enabled=not args.quiet
            ) as bar:

                def tick(result: Any) -> None:
                    wins = sum(o.success for o in result.outcomes)
                    bar.set_postfix_str(
                        f"repetition {result.index}: {wins}/{len(result.outcomes)} trials"
                        " succeeded",
                        refresh=False,
                    )
                    bar.update(1)

                reps = runner.run_benchmark(
                    config, stage / "repetitions", workers=workers, progress=tick
                )
            wall = time.perf_counter() - start
            text = report.write_benchmark_outputs(stage, config, reps, wall_s=wall, workers=workers)
    except (KeyboardInterrupt, Terminated) as exc:
        code = interrupted_exit_code(exc)
        print(f"lfd-track benchmark: interrupted; {shown_path(out)} is as it was", file=sys.stderr)
        return code
    finally:
        signal.signal(signal.SIGTERM, previous)
    print(text)
    print(
        f"\nreport: {shown_path(out / 'report.md')}\nresults: {shown_path(out / 'results.json')}"
        f"\nplots: {shown_path(out / 'trajectories.png')}, {shown_path(out / 'fitness.png')}"
    )
    return EXIT_OK
