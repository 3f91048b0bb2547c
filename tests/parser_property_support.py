"""What the parser property tests share: one search budget, the outcome count, TOML values.

Each of the four file parsers (demonstration, controller, track, preset) has its property tests
beside the tests of its subpackage; for any input, a parser either returns a valid object or
raises ``FileFormatError`` whose message is one line starting with the file's name, never another
exception, never a hang. Run a property module with ``-s`` to see how many inputs each property
tried and how many were refused cleanly.
"""

from __future__ import annotations

import json
import math
import os
from collections import Counter
from collections.abc import Callable
from pathlib import Path
from typing import Any

from hypothesis import HealthCheck, settings
from hypothesis import strategies as st

from lfd_track.errors import FileFormatError

# LFD_PROPERTY_EXAMPLES=2000 runs a deeper, randomly seeded search; by default the same 150
# inputs per property on every run.
_DEEP = int(os.environ.get("LFD_PROPERTY_EXAMPLES", "0"))
SETTINGS = settings(
    max_examples=_DEEP or 150,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
    derandomize=not _DEEP,  # the same inputs on every run: a failure always reproduces
)
COUNTS: dict[str, Counter] = {}


def print_counts() -> None:
    """Print (``-s`` shows it) and forget the outcome counts of the properties run so far."""
    for name, counts in sorted(COUNTS.items()):
        print(
            f"\n{name}: {counts['tried']} inputs, {counts['accepted']} accepted,"
            f" {counts['refused']} refused cleanly"
        )
    COUNTS.clear()


def outcome(name: str, path: Path, load: Callable[[Path], Any]) -> Any:
    """Load ``path``; count the outcome; a refusal must be one line naming the file."""
    counts = COUNTS.setdefault(name, Counter())
    counts["tried"] += 1
    try:
        result = load(path)
    except FileFormatError as exc:
        message = str(exc)
        assert message.startswith(f"{path}: "), message
        assert "\n" not in message and len(message) < 2000
        counts["refused"] += 1
        return None
    counts["accepted"] += 1
    return result


NUMBERS = (
    st.floats(allow_nan=True, allow_infinity=True)
    | st.floats(-10, 10)
    | st.integers(-(10**20), 10**20)
)
TOML_SCALARS = st.booleans() | st.text(max_size=10) | NUMBERS


def toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return (
            "nan"
            if math.isnan(value)
            else ("inf" if value > 0 else "-inf")
            if math.isinf(value)
            else repr(value)
        )
    if isinstance(value, int):
        return str(value)
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, list):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    raise TypeError(value)
