"""``lfd-track sample-data``: unpack the shipped sample demonstrations into a folder."""

from __future__ import annotations

import argparse
from typing import Any

from ..utils.outputs import shown_path
from .types import EXIT_OK


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add ``sample-data`` to the ``lfd-track`` commands."""
    sample = subparsers.add_parser(
        "sample-data",
        help="write the shipped sample demonstrations into a folder",
        description="Write three short demonstrations shipped with lfd-track (the scripted human"
        " driving the training track once, seeds 0-2) into a folder, to learn from without"
        " running the simulator first.",
    )
    sample.add_argument("folder", metavar="DIR", help="folder to write into (made if missing)")
    sample.add_argument("--force", action="store_true", help="replace existing files")
    sample.set_defaults(func=run)
    return sample


def run(args: argparse.Namespace) -> int:
    """The ``sample-data`` command."""
    from ..dataset.sample import write_sample_data

    for path, demo in write_sample_data(args.folder, force=args.force):
        counts = demo.command_counts
        print(
            f"{shown_path(path)}: {demo.n_cases} cases ({counts['forward']} forward,"
            f" {counts['left']} left, {counts['right']} right)"
        )
    return EXIT_OK
