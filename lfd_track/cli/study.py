"""``lfd-track study``: conditions x seeds of the paper protocol, resumable; writes DIR/study.json,
study.md and study.png."""

from __future__ import annotations

import argparse
import signal
import sys
from pathlib import Path
from typing import Any

from ..errors import LfdTrackError
from ..study.run import load_finished, locked_out, run_study
from ..study.spec import load_study
from ..utils.outputs import refuse_unsafe_output, shown_path
from ..utils.signals import Terminated, interrupted_exit_code, raise_terminated
from .types import EXIT_OK
from .types import positive_int as _workers


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add ``study`` to the ``lfd-track`` commands."""
    study = subparsers.add_parser(
        "study",
        help="run a study: conditions x seeds of the paper protocol, with 95 %% intervals",
        description=(
            "Run every (condition, seed) job of a study file as one paper-protocol benchmark, "
            "skipping jobs finished by an earlier run, then write DIR/study.json, study.md and "
            "study.png."
        ),
    )
    study.add_argument("study_file", metavar="STUDY.toml", help="the study file")
    study.add_argument("--out", required=True, help="output folder (one subfolder per job)")
    study.add_argument(
        "--executor",
        choices=("local", "ray"),
        default="local",
        help="local processes (default) or Ray tasks (needs lfd-track[cluster])",
    )
    study.add_argument(
        "--address",
        default=None,
        help="Ray cluster address, e.g. 'auto' or 'HOST:6379' (default: start a local Ray)",
    )
    study.add_argument(
        "--workers",
        type=_workers,
        default=1,
        help="jobs run at once: local processes, or the CPUs of a local Ray (default 1)",
    )
    study.set_defaults(func=run)
    return study


def run(args: argparse.Namespace) -> int:
    """The ``study`` command."""
    # Lazy: the summary draws study.png (the drawing stack, OpenCV) only when a study runs.
    from ..study.summary import write_study_outputs

    if args.address is not None and args.executor != "ray":
        raise LfdTrackError("--address needs --executor ray")
    study = load_study(args.study_file)  # a bad study file fails here, before DIR is touched
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise LfdTrackError(f"{out}: exists and is not a folder")
    refuse_unsafe_output(out, folder=True)  # a symbolic link to a folder too
    for name in ("study.json", "study.md", "study.png", "study.csv"):
        refuse_unsafe_output(out / name)
    out.mkdir(parents=True, exist_ok=True)
    show = not args.quiet and sys.stderr.isatty()
    with locked_out(out):  # one study at a time per folder; refused before any job runs
        # SIGTERM stops the study like Ctrl-C: the jobs still running are stopped (worker
        # processes too), the finished ones are kept.
        previous = signal.signal(signal.SIGTERM, raise_terminated)
        try:
            done = run_study(
                study,
                out,
                executor=args.executor,
                workers=args.workers,
                address=args.address,
                progress=show,
            )
        except (KeyboardInterrupt, Terminated) as exc:
            code = interrupted_exit_code(exc)
            print(
                f"lfd-track study: interrupted; the finished jobs are kept in {shown_path(out)}"
                " (run the same command to resume)",
                file=sys.stderr,
            )
            return code
        finally:
            signal.signal(signal.SIGTERM, previous)
        results = write_study_outputs(out, study, load_finished(study, out))
    for c in results["conditions"]:
        testing = c["testing"]
        low, high = testing["ci95"]
        print(
            f"{c['name']}: testing {testing['successes']}/{testing['trials']} "
            f"[{100 * low:.0f}–{100 * high:.0f} %], training "
            f"{c['training']['successes']}/{c['training']['trials']}"
        )
    again = ""
    if done.again:
        whose = "its worker process" if done.again == 1 else "their worker processes"
        again = f" ({done.again} again after {whose} died)"
    print(
        f"{done.ran} jobs run{again}, {done.skipped} already finished, {done.wall_s:.0f} s; "
        f"tables {out / 'study.md'}, results {out / 'study.json'}, plot {out / 'study.png'}"
    )
    return EXIT_OK
