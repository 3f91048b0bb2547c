"""Argument types shared by every ``lfd-track`` command (one-line usage errors), and exit codes."""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable
from typing import Any

from ..learning.result import shown_int
from ..utils.signals import EXIT_INTERRUPTED, EXIT_TERMINATED

EXIT_OK, EXIT_ERROR, EXIT_USAGE = 0, 1, 2
EXIT_CODES = (EXIT_OK, EXIT_ERROR, EXIT_USAGE, EXIT_INTERRUPTED, EXIT_TERMINATED)
"""Every exit code of the commands (130, 143: stopped by Ctrl-C, SIGTERM; see signals.py)."""


def _whole_number(text: str) -> int:
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None


def positive_int(text: str) -> int:
    """A whole number >= 1 (counts of laps, workers, repetitions)."""
    value = _whole_number(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {value}")
    return value


def non_negative_int(text: str) -> int:
    """A whole number >= 0 (seeds, counts that may be zero)."""
    value = _whole_number(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be >= 0, got {value}")
    return value


def _number(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None


def positive_float(text: str) -> float:
    """A finite number > 0 (periods in seconds, rates)."""
    value = _number(text)
    if not value > 0 or not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be a positive number, got {text}")
    return value


def share(text: str) -> float:
    """A fraction in (0, 1] (agreement thresholds)."""
    value = _number(text)
    if not 0.0 < value <= 1.0:
        raise argparse.ArgumentTypeError(f"must be in (0, 1], got {text}")
    return value


def port(text: str) -> int:
    """A TCP port, 0..65535 (0: let the system pick a free one)."""
    value = _whole_number(text)
    if not 0 <= value <= 65535:
        raise argparse.ArgumentTypeError(f"port must be in 0..65535, got {value}")
    return value


def whole_number_in(low: int, high: int) -> Callable[[str], int]:
    """An argparse type: a whole number in ``low..high``; the error never prints a huge number
    whole."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            shown = text if len(text) <= 30 else f"{text[:30]}... ({len(text)} characters)"
            raise argparse.ArgumentTypeError(f"expected a whole number, got {shown!r}") from None
        if value < low:
            raise argparse.ArgumentTypeError(f"must be at least {low}, got {shown_int(value)}")
        if value > high:
            raise argparse.ArgumentTypeError(f"must be at most {high}, got {shown_int(value)}")
        return value

    return parse


def float_in(low: float, high: float) -> Callable[[str], float]:
    """An argparse type: a number in [low, high] (one-line usage error otherwise)."""

    def parse(text: str) -> float:
        value = positive_float(text)
        if not low <= value <= high:
            raise argparse.ArgumentTypeError(f"must be in {low:g}..{high:g}, got {text}")
        return value

    return parse


#: The ``MemoryConfig`` fields :func:`add_map_arguments` offers.
_MAP_SETTINGS = (
    "blank_bearing",
    "bearing_range_deg",
    "strip_link_m",
    "blank_reach_m",
    "visited_fade_m",
    "blank_distance",
    "strip_picture_links",
    "path_places",
)


def add_map_arguments(parser: argparse.ArgumentParser) -> None:
    """The ``fresh_felt`` map's options a command line offers (``MemoryConfig``'s fields of
    the same names; :func:`map_settings` reads them back)."""
    from ..policy.memory import (
        BLANK_BEARINGS,
        BLANK_DISTANCES,
        FULL_BEARING_RANGE_DEG,
        PATH_PLACES,
    )

    parser.add_argument(
        "--blank-bearing",
        choices=BLANK_BEARINGS,
        default="centre",
        help="with --memory fresh_felt: the bearing input while no fresh felt is left: centre"
        " (0.5, default) or last (the side the fresh felt last lay on)",
    )
    parser.add_argument(
        "--bearing-range",
        dest="bearing_range_deg",
        type=float_in(1.0, FULL_BEARING_RANGE_DEG),
        default=FULL_BEARING_RANGE_DEG,
        metavar="DEG",
        help="with --memory fresh_felt: the bearing the bearing input maps to 1 and 0, bearings"
        " beyond it clipped (default 180, the whole circle; the goal's chosen policy: 30)",
    )
    # Options of a length in metres, off (0) unless given: flag, MemoryConfig field, range, help.
    for flag, dest, low, high, text in (
        (
            "--strip-link", "strip_link_m", 0.01, 1.0,
            "only felt connected along felt to the rover's own strip, by links of at most M"
            " metres, is fresh (default off; the goal's chosen policy: 0.15)",
        ),
        (
            "--blank-reach", "blank_reach_m", 0.1, 5.0,
            "while nothing is fresh within reach (0.6 m), look again up to M metres (default"
            " off; the goal's chosen policy: 1.0)",
        ),
        (
            "--visited-fade", "visited_fade_m", 0.01, 2.0,
            "fresh felt weighs from 0 at the path radius up to full M metres beyond it (default"
            " off; the goal's chosen policy: 0.3)",
        ),
    ):  # fmt: skip
        parser.add_argument(
            flag,
            dest=dest,
            type=float_in(low, high),
            default=0.0,
            metavar="M",
            help=f"with --memory fresh_felt: {text}",
        )
    parser.add_argument(
        "--blank-distance",
        choices=BLANK_DISTANCES,
        default="blank_reach",
        help="with --blank-reach: the distance input of felt found further, over the blank reach"
        " (default) or over the reach, clipped to 1 (the goal's chosen policy: reach)",
    )
    parser.add_argument(
        "--strip-picture-links",
        action="store_true",
        help="with --strip-link: felt regions that touch in one frame's grid are linked too"
        " (the goal's chosen policy)",
    )
    parser.add_argument(
        "--path-places",
        choices=PATH_PLACES,
        default="every_command",
        help="with --memory fresh_felt: which commands leave a place on the map's path:"
        " every_command (default) or forward (pivots on the spot do not)",
    )


def map_settings(args: argparse.Namespace) -> dict[str, Any]:
    """The ``MemoryConfig`` keyword arguments of the options :func:`add_map_arguments` added
    (each option's destination is the field's name)."""
    return {name: getattr(args, name) for name in _MAP_SETTINGS}
