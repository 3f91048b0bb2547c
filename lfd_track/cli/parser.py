"""The ``lfd-track`` argument parser and entry point; each command lives in a module of its own.

User errors (bad files, unknown tracks, bad flags) print one line to stderr and exit 1 (2 for bad
usage); nothing already saved is overwritten by a half-written file (every output is written
atomically or, for demonstrations, crash-safely). An output only ever replaces a regular file:
one whose name is a symbolic link (wherever it points), a device, a FIFO or a socket is refused
before any work (see utils/outputs.py). Names that are not valid UTF-8 are shown with \\x
escapes (in messages and on plots); a track or preset name that a recording or a benchmark would
record must be UTF-8 and is otherwise refused before any work.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from typing import NoReturn

from ..errors import LfdTrackError
from ..utils.signals import EXIT_INTERRUPTED
from . import (
    benchmark,
    demo,
    drive,
    evaluate,
    evolve,
    export,
    hardware,
    sample,
    study,
    teach,
    tracks,
)
from .types import EXIT_CODES, EXIT_ERROR, EXIT_USAGE

__all__ = ["EXIT_CODES", "build_parser", "main"]


class _Parser(argparse.ArgumentParser):
    """An argument parser whose usage errors are one line."""

    def error(self, message: str) -> NoReturn:
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message} (see --help)\n")


def build_parser() -> argparse.ArgumentParser:
    """The ``lfd-track`` argument parser."""
    parser = _Parser(
        prog="lfd-track",
        description="Learning from demonstration with encapsulated evolution on a felt-track rover.",
        epilog="Outputs: an existing file is replaced only where a command says so (--force);"
        " an output name that is a symbolic link, a device, a FIFO or a socket is always refused."
        " Track and preset names recorded in a recording or in benchmark results must be UTF-8.",
    )
    parser.add_argument(
        "--quiet",
        "-q",
        action="store_true",
        help="no progress bars (they are shown only when stderr is a terminal anyway)",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True
    for command in (
        demo,
        sample,
        evolve,
        export,
        drive,
        benchmark,
        evaluate,
        study,
        teach,
        hardware,
        tracks,
    ):
        command.add_parser(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``lfd-track`` console script."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except KeyboardInterrupt:
        print("lfd-track: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except OSError as exc:
        where = exc.filename if exc.filename is not None else ""
        message = (
            f"{where}: {exc.strerror}" if where and exc.strerror else str(exc) or type(exc).__name__
        )
        print(f"lfd-track {args.command}: {message.splitlines()[0]}", file=sys.stderr)
        return EXIT_ERROR
    except (LfdTrackError, ValueError, OverflowError, RecursionError) as exc:
        message = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        print(f"lfd-track {args.command}: {message}", file=sys.stderr)
        return EXIT_ERROR
