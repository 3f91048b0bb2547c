"""``lfd-track export minari``: demonstrations as a Minari dataset of ``LfDTrack-v0``.

What the dataset holds, and how learning reads it back (``lfd-track evolve --minari``), is
described in :mod:`lfd_track.dataset.minari`.
"""

from __future__ import annotations

import argparse
from typing import Any

from ..utils.outputs import shown_path
from .types import EXIT_OK


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add ``export`` (with its one format, ``minari``) to the ``lfd-track`` commands."""
    export = subparsers.add_parser(
        "export",
        help="write demonstrations in another format (a Minari dataset)",
        description="Write demonstrations in another format.",
    )
    formats = export.add_subparsers(dest="format", metavar="FORMAT", parser_class=type(export))
    formats.required = True
    minari = formats.add_parser(
        "minari",
        help="a Minari dataset of LfDTrack-v0 (needs the minari extra)",
        description="Write .lfdemo demonstrations as one Minari dataset of LfDTrack-v0: road"
        " values as observations, the commands as Discrete(3) actions, and the road library and"
        " env spec that recover_environment() and lfd-track evolve --minari need.",
    )
    minari.add_argument("demos", nargs="+", metavar="DEMO", help="demonstration files (.lfdemo)")
    minari.add_argument(
        "--dataset-id", required=True, help="Minari dataset id, e.g. lfd-track/training-v0"
    )
    minari.add_argument(
        "--observations",
        choices=("road-values", "frames"),
        default="road-values",
        help="what the observations are (default: road-values; frames: replayed from a scripted demonstration's seed)",
    )
    minari.add_argument(
        "--datasets-path",
        default=None,
        help="Minari datasets folder (default: Minari's own, MINARI_DATASETS_PATH or ~/.minari/datasets)",
    )
    minari.add_argument(
        "--force", action="store_true", help="replace an existing dataset of that id"
    )
    minari.set_defaults(func=run_minari)
    return export


def run_minari(args: argparse.Namespace) -> int:
    """The ``export minari`` command."""
    from ..dataset.minari import cases_from_minari, export_minari

    folder = export_minari(
        args.demos,
        args.dataset_id,
        observations=args.observations,
        datasets_path=args.datasets_path,
        force=args.force,
    )
    cases = cases_from_minari(args.dataset_id, datasets_path=args.datasets_path)
    episodes = _plural(cases.n_episodes, "episode")
    files = _plural(len(args.demos), "demonstration")
    print(
        f"Minari dataset {args.dataset_id}: {cases.n_cases} cases in {episodes} of {files},"
        f" in {shown_path(folder)}"
    )
    return EXIT_OK


def _plural(n: int, noun: str) -> str:
    return f"{n} {noun}" if n == 1 else f"{n} {noun}s"
