"""Compare two results.json files key by key, both read through the results migration.

    python scripts/compare_results.py results/paper/results.json \\
        benchmarks/experiments/paper_protocol/results/seed0/results.json

Prints every key whose value differs or that only one file has, ignoring ``timing_s`` and
``environment`` (how long it took, and on what); prints nothing else when the runs agree.
Exit status 1 when they differ.
"""

from __future__ import annotations

import sys
from typing import Any

from lfd_track.benchmark.schema import read_results

IGNORED = {"timing_s", "environment"}


def differences(new: Any, old: Any, path: str = "") -> list[str]:
    """Where ``new`` and ``old`` differ, as paths with both values."""
    if isinstance(new, dict) and isinstance(old, dict):
        found = []
        for key in sorted(set(new) | set(old)):
            if not path and key in IGNORED:
                continue
            if key not in new or key not in old:
                found.append(f"only in {'the first' if key in new else 'the second'}: {path}/{key}")
            else:
                found += differences(new[key], old[key], f"{path}/{key}")
        return found
    if isinstance(new, list) and isinstance(old, list) and len(new) == len(old):
        return [
            d
            for i, (a, b) in enumerate(zip(new, old, strict=True))
            for d in differences(a, b, f"{path}[{i}]")
        ]
    return [] if new == old else [f"differs: {path}: {str(new)[:80]} | {str(old)[:80]}"]


def main(argv: list[str]) -> int:
    if len(argv) != 2:
        print("usage: compare_results.py FIRST/results.json SECOND/results.json", file=sys.stderr)
        return 2
    found = differences(read_results(argv[0]), read_results(argv[1]))
    print("\n".join(found) if found else "same (apart from timing_s and environment)")
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
