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


def unit_interval(text: str) -> float:
    """A number in [0, 1] (exponents and weights where 0 is a setting of its own)."""
    value = _number(text)
    if not 0.0 <= value <= 1.0:
        raise argparse.ArgumentTypeError(f"must be in 0..1, got {text}")
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


def _setting_flag(name: str) -> str:
    """The command-line flag of a memory setting: its name, less its unit, with dashes
    (``strip_link_m`` -> ``--strip-link``)."""
    for unit in ("_m", "_deg"):
        if name.endswith(unit):
            name = name[: -len(unit)]
    return "--" + name.replace("_", "-")


def _setting_type(spec: Any) -> Callable[[str], Any]:
    """An argparse type checking a number against the bounds its setting declares (the
    setting's own check, so a flag and a study file refuse the same values)."""
    parse_number = _whole_number if spec.type is int else _number

    def parse(text: str) -> Any:
        value = parse_number(text)
        problem = spec.problem(value)
        if problem:
            raise argparse.ArgumentTypeError(problem)
        return value

    return parse


def add_map_arguments(parser: argparse.ArgumentParser) -> None:
    """One flag per setting of the ``fresh_felt`` map
    (:class:`~lfd_track.policy.memory_config.FreshFeltConfig`: its name less its unit, its bounds,
    its help line); a flag not given leaves the class's default. :func:`memory_from_args` reads
    them back."""
    from ..policy.memory_config import FreshFeltConfig, setting_specs

    for spec in setting_specs(FreshFeltConfig):
        shown = spec.default if spec.type is str else str(spec.default).lower()
        options: dict[str, Any] = {
            "dest": spec.name,
            "default": None,
            "help": f"with --memory fresh_felt: {spec.doc} (default {shown})",
        }
        if spec.type is bool:
            options["action"] = argparse.BooleanOptionalAction
        elif spec.choices is not None:
            options["choices"] = spec.choices
        else:
            options["type"] = _setting_type(spec)
            options["metavar"] = "DEG" if spec.name.endswith("_deg") else "M"
        parser.add_argument(_setting_flag(spec.name), **options)


def map_settings(args: argparse.Namespace) -> dict[str, Any]:
    """The ``fresh_felt`` settings given on the command line (the flags of
    :func:`add_map_arguments`; each flag's destination is the setting's name)."""
    from ..policy.memory_config import FreshFeltConfig, setting_specs

    given = ((spec.name, getattr(args, spec.name, None)) for spec in setting_specs(FreshFeltConfig))
    return {name: value for name, value in given if value is not None}


def memory_from_args(args: argparse.Namespace) -> Any:
    """The :class:`~lfd_track.policy.memory_config.MemoryConfig` of ``--memory`` and the map's
    flags. ``ValueError`` (one line) for a map flag without ``--memory fresh_felt`` or settings
    that do not go together."""
    from ..policy.memory_config import memory_config

    settings = map_settings(args)
    if settings and args.memory != "fresh_felt":
        flag = _setting_flag(next(iter(settings)))
        raise ValueError(f"{flag} is a setting of the fresh_felt map: give --memory fresh_felt")
    return memory_config({"kind": args.memory, **settings})
