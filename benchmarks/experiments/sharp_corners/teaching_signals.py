"""Part 54 of ``README.md``: does anything a study job records about a repetition's teaching tell
a room whose learner laps under 85 % of its loop laps (committed results only; it chooses
nothing for the product)?

    .venv/bin/python benchmarks/experiments/sharp_corners/teaching_signals.py

For the goal's learner on the goal's map in the 30 rooms of ``rooms30.toml`` (parts 51-53: taught
first, taught again, refitted), per signal: the threshold and side chosen on the first teaching
(the most rooms under the bar flagged less rooms at it flagged, as shares; ties to fewer at the
bar flagged), and what it flags of the other two teachings' rooms under the bar and at it.
Writes ``results/teaching_signals.md``.
"""

from __future__ import annotations

import json
import math
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE), str(HERE.parent / "human_goal")]

from room_measures import repetition_laps, write_page  # noqa: E402
from rooms30 import CONDITION, RESULTS, SEEDS  # noqa: E402
from rooms_breakdown import BAR  # noqa: E402

#: the teaching chosen on, and the two read on (parts 51-53)
CHOSEN_ON = RESULTS / "rooms30" / CONDITION
READ_ON = (RESULTS / "rooms30_again" / CONDITION, RESULTS / "rooms30_refit" / CONDITION)
BAR_LAPS = math.ceil(BAR * 20)  # of a room's 20 loop laps
OUT = RESULTS / "teaching_signals.md"
#: signal: its value for one repetition from the job's record, the repetition's index and its
#: (loop laps, training-track runs) lapped (``room_measures.repetition_laps``)
SIGNALS: dict[str, Callable[[dict[str, Any], int, tuple[int, int]], float]] = {
    "training accuracy": lambda d, r, laps: d["training_accuracy"][r],
    "training-track runs lapped": lambda d, r, laps: laps[1],
    "human commands": lambda d, r, laps: d["human_effort"]["repetitions"][r]["commands"],
    "demonstration cases": lambda d, r, laps: d["demonstrations"][r]["cases"],
    "demonstration turns": lambda d, r, laps: (
        d["demonstrations"][r]["counts"]["left"] + d["demonstrations"][r]["counts"]["right"]
    ),
    "road library models": lambda d, r, laps: d["demonstrations"][r]["library_models"],
    "best fitness": lambda d, r, laps: d["best_fitness"][r],
}


def teachings(folder: Path) -> list[tuple[bool, dict[str, float]]]:
    """Per repetition under ``folder``: (under the bar, each signal's value)."""
    out = []
    for seed in SEEDS:
        data = json.loads((folder / f"seed{seed}" / "results.json").read_text(encoding="utf-8"))
        laps = repetition_laps(folder / f"seed{seed}")
        for r in range(data["repetitions"]):
            values = {name: float(f(data, r, laps[r])) for name, f in SIGNALS.items()}
            out.append((laps[r][0] < BAR_LAPS, values))
    return out


def flagged(rows: list[tuple[bool, dict[str, float]]], name: str, cut: float, low: bool) -> tuple:
    """(under the bar flagged, under, at the bar flagged, at the bar) when ``name`` at or below
    (``low``) or at or above ``cut`` flags a teaching."""
    hit = [(under, v[name] <= cut if low else v[name] >= cut) for under, v in rows]
    under = [h for u, h in hit if u]
    at_bar = [h for u, h in hit if not u]
    return sum(under), len(under), sum(at_bar), len(at_bar)


def main() -> None:
    first = teachings(CHOSEN_ON)
    later = [row for folder in READ_ON for row in teachings(folder)]
    md = ["# Part 54: teaching-time records as a check for a room's learner short of the bar", ""]
    md += ["Chosen on the first teaching (30 rooms), read on the second and the refit (60):", ""]
    md += ["| signal | flags | on the first: under / at the bar | on the other two | candidate |"]
    md += ["|---|---|---|---|---|"]
    for name in SIGNALS:
        best = None
        for cut in sorted({v[name] for _, v in first}):
            for low in (True, False):
                u, nu, a, na = flagged(first, name, cut, low)
                score = (u / nu - a / na, -a)
                if best is None or score > best[0]:
                    best = (score, cut, low)
        assert best is not None
        _, cut, low = best
        u, nu, a, na = flagged(first, name, cut, low)
        lu, lnu, la, lna = flagged(later, name, cut, low)
        candidate = lu * 2 >= lnu and la * 5 <= lna
        md += [
            f"| {name} | {'<=' if low else '>='} {cut:g} | {u}/{nu} / {a}/{na} | "
            f"{lu}/{lnu} / {la}/{lna} | {'yes' if candidate else 'no'} |"
        ]
    write_page(OUT, md)


if __name__ == "__main__":
    main()
