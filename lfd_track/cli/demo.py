"""``lfd-track demo``: record the scripted human's demonstration protocol in the simulator.

Without ``--force`` the recording goes straight to its name: interrupted, it is still there,
visible and usable. With ``--force`` an existing file is kept until the new one is complete (see
:class:`~lfd_track.dataset.recording.RecordingTarget`).
"""

from __future__ import annotations

import argparse
import signal
import sys
from pathlib import Path
from typing import Any

from ..dataset import load_demonstration
from ..dataset.recording import RecordingTarget
from ..demo import demonstrator
from ..errors import LfdTrackError
from ..utils.outputs import refuse_undecodable, shown_path, taken
from ..utils.signals import Terminated, interrupted_exit_code, raise_terminated
from .outputs import check_output
from .types import EXIT_OK
from .types import non_negative_int as _seed


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add ``demo`` to the ``lfd-track`` commands."""
    demo = subparsers.add_parser(
        "demo",
        help="record a scripted human demonstration in the simulator",
        description="Drive the paper's demonstration protocol with the scripted human and record every case.",
    )
    demo.add_argument(
        "--track", default="training", help="open track to demonstrate on (default: training)"
    )
    demo.add_argument(
        "--seed", type=_seed, default=0, help="seed of the human and the world (default: 0)"
    )
    demo.add_argument(
        "--preset", default="paper", help="environment preset name or TOML path (default: paper)"
    )
    demo.add_argument(
        "--careless",
        action="store_true",
        help="keep learning the road library while the safe box is off the felt (the paper's warning)",
    )
    demo.add_argument("--force", action="store_true", help="replace an existing output file")
    demo.add_argument("--out", required=True, help="demonstration file to write (.lfdemo)")
    demo.set_defaults(func=run)
    return demo


def run(args: argparse.Namespace) -> int:
    """The ``demo`` command."""
    # Lazy: the drawing and progress-bar stack (OpenCV, tqdm) loads only when the command runs.
    from ..utils.progress import progress_bar

    out = Path(args.out)
    check_output(out, [("track", args.track), ("preset", args.preset)])
    for what, name in (("track", args.track), ("preset", args.preset)):
        refuse_undecodable(name, what)  # recorded in the file's metadata
    if taken(out) and not args.force:
        raise LfdTrackError(
            f"{shown_path(out)}: already exists; an earlier recording is never replaced"
            " (use --force to replace it)"
        )
    human = demonstrator.HumanConfig(careful=not args.careless)
    target = RecordingTarget(out, replace=out.exists())
    commands = 0

    def progress(n: int) -> None:
        nonlocal commands
        commands = n
        bar.update(n - bar.n)

    previous = signal.signal(signal.SIGTERM, raise_terminated)
    try:
        # A running count: how many commands the protocol takes is known only when it ends.
        with progress_bar(None, "demonstrating", unit=" commands", enabled=not args.quiet) as bar:
            summary = demonstrator.run_demonstration(
                target.path,
                seed=args.seed,
                track=args.track,
                preset=args.preset,
                human=human,
                overwrite=args.force and not target.replacing,
                progress=progress,
            )
    except (KeyboardInterrupt, Terminated) as exc:
        code = interrupted_exit_code(exc)
        if not target.path.exists():
            print("lfd-track demo: interrupted before anything was recorded", file=sys.stderr)
            return code
        kept_at = target.keep()
        try:
            kept = f"{load_demonstration(kept_at).n_cases} cases"
        except LfdTrackError:
            kept = "no usable cases"
        print(
            f"lfd-track demo: interrupted after {commands} commands; the partial recording"
            f" ({kept}) is kept at {shown_path(kept_at)} (lfd-track evolve can train on it)",
            file=sys.stderr,
        )
        return code
    except BaseException:
        target.discard()  # an unfinished replacement; the earlier recording is untouched
        raise
    finally:
        signal.signal(signal.SIGTERM, previous)
    target.commit()
    print(
        f"{shown_path(out)}: {summary.n_cases} cases ({summary.counts['forward']} forward, "
        f"{summary.counts['left']} left, {summary.counts['right']} right), "
        f"turn-arounds {', '.join(summary.turnarounds)}, library {summary.library_models} models "
        f"in {summary.library_types} types"
    )
    return EXIT_OK
