"""``lfd-track evaluate``: score a policy (a controller file, or anyone's function or agent) with
the benchmark's corner-success protocol; its output folder changes only when the whole run has
succeeded (:mod:`lfd_track.utils.staging`)."""

from __future__ import annotations

import argparse
import signal
import sys
from pathlib import Path
from typing import Any

from ..benchmark import runner
from ..benchmark.evaluation import DEFAULT_TRACKS, OBSERVATIONS
from ..utils.outputs import refuse_undecodable, refuse_unsafe_output, shown_path
from ..utils.signals import Terminated, interrupted_exit_code, raise_terminated
from ..utils.staging import staged_output
from .types import EXIT_OK, whole_number_in


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add ``evaluate`` to the ``lfd-track`` commands."""
    evaluate = subparsers.add_parser(
        "evaluate",
        help="score a policy with the paper's corner-success protocol",
        description="Drive a policy both ways on the training track and the testing track (laps"
        " from corner 4), as lfd-track benchmark drives the controllers it learns, and count its"
        " failures corner by corner as in the paper's Tables 2 and 3, with Wilson 95 % intervals.",
    )
    evaluate.add_argument(
        "--policy",
        required=True,
        metavar="POLICY",
        help="a controller file (.json), or module:name / file.py:name naming a function"
        " obs -> action (0 forward, 1 left, 2 right) or an object with predict(obs) or act(obs);"
        " modules are looked up in the current folder first",
    )
    evaluate.add_argument(
        "--tracks",
        nargs="+",
        default=list(DEFAULT_TRACKS),
        metavar="TRACK",
        help="tracks driven both ways: training and loops with corners (names or .toml paths)"
        " (default: training testing)",
    )
    evaluate.add_argument(
        "--laps",
        type=whole_number_in(1, runner.MAX_TRIALS_PER_DIRECTION),
        default=3,
        help=f"runs per track and direction, at most {runner.MAX_TRIALS_PER_DIRECTION}"
        " (default: 3)",
    )
    evaluate.add_argument(
        "--seed",
        type=whole_number_in(0, runner.MAX_SEED),
        default=0,
        help=f"seed of the worlds, 0..{runner.MAX_SEED}: those of lfd-track benchmark --seed"
        " (default: 0)",
    )
    evaluate.add_argument(
        "--observation",
        choices=OBSERVATIONS,
        default="frames",
        help="what the policy reads: camera frames, or their 40 road values (needs --library)"
        " (default: frames; a controller file reads frames through its own library)",
    )
    evaluate.add_argument(
        "--library",
        metavar="FILE",
        default=None,
        help="road library for --observation road-values: a controller file (.json) or a"
        " demonstration (.lfdemo), e.g. from lfd-track demo",
    )
    evaluate.add_argument(
        "--preset", default="paper", help="environment preset name or TOML path (default: paper)"
    )
    evaluate.add_argument(
        "--out",
        default=None,
        help="output folder (results.json, report.md, trajectories.png and .csv)",
    )
    evaluate.set_defaults(func=run)
    return evaluate


def run(args: argparse.Namespace) -> int:
    """The ``evaluate`` command."""
    # Lazy: the policy, the drawing and progress-bar stack load only when the command runs.
    from ..benchmark.evaluation import evaluate
    from ..utils.progress import progress_bar

    # Names recorded in results.json and report.md, which hold text only.
    for what, name in (
        ("policy", args.policy),
        ("preset", args.preset),
        *(("track", track) for track in args.tracks),
        *((("library", args.library),) if args.library else ()),
    ):
        refuse_undecodable(name, what)
    out = Path(args.out) if args.out is not None else None
    if out is not None:
        refuse_unsafe_output(out, folder=True)
    runs = 2 * len(args.tracks) * args.laps
    options = dict(
        tracks=args.tracks,
        laps=args.laps,
        seed=args.seed,
        observation=args.observation,
        library=args.library,
        preset=args.preset,
        name=args.policy,
    )
    previous = signal.signal(signal.SIGTERM, raise_terminated)
    try:
        with progress_bar(runs, "evaluate", unit=" runs", enabled=not args.quiet) as bar:

            def tick(outcome: Any) -> None:
                bar.set_postfix_str(
                    f"{outcome.track} {outcome.direction}: "
                    + ("success" if outcome.success else str(outcome.failure)),
                    refresh=False,
                )
                bar.update(1)

            if out is None:
                result = evaluate(args.policy, progress=tick, **options)
            else:
                # Written to a staging folder that replaces the previous output only once the
                # whole run has succeeded: a failing policy leaves the previous output as it was.
                with staged_output(out) as stage:
                    result = evaluate(args.policy, progress=tick, out=stage, **options)
    except (KeyboardInterrupt, Terminated) as exc:
        code = interrupted_exit_code(exc)
        kept = f"; {shown_path(out)} is as it was" if out is not None else ""
        print(f"lfd-track evaluate: interrupted{kept}", file=sys.stderr)
        return code
    finally:
        signal.signal(signal.SIGTERM, previous)
    from ..benchmark.evaluation import rates_section

    print(result.tables())
    print(rates_section(result.results).rstrip("\n"))
    if out is not None:
        print(
            f"\nreport: {shown_path(out / 'report.md')}\nresults: {shown_path(out / 'results.json')}"
            f"\nplots: {shown_path(out / 'trajectories.png')}"
        )
    return EXIT_OK
