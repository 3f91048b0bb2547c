"""Is the bar "every room at 85 % of its loop laps" bound by the rooms? The same repetitions
without a room, from the committed test results.

Round 27's winner was scored once on the test split in the paper world (``test_paper27.toml``,
``seeds3to5_paper27.toml``) and in rooms of their own (``test_rooms27.toml``,
``seeds3to5_rooms27.toml``). A study seed and repetition give the same demonstration seeds, trial
seeds and ten procedural test loops in both worlds (checked here: a repetition whose loops differ
is left out of the pairing), so the paper world's repetition is the room's repetition without its
room. This script pairs them and asks how many repetitions reach 85 % of their 20 loop laps (17)
in each world, in both, in one only; how that compares with chance (every repetition lapping at
its world's pooled rate); and which loops the short repetitions lose, by their sharpest turn.

It reads committed results only and chooses nothing; a design it suggests is chosen on
validation rooms, as every round is.

Run: ``.venv/bin/python benchmarks/experiments/human_goal/test_round27/every_room.py`` — writes
``results/every_room.md`` beside this file.
"""

from __future__ import annotations

import math
import sys
from collections import Counter
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from room_measures import loop_laps, spearman, write_page  # noqa: E402

from lfd_track.benchmark.loops import loop_facts  # noqa: E402
from lfd_track.world.loops import turn_bin  # noqa: E402

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "results"
PAIRS = (("test_paper27", "test_rooms27"), ("seeds3to5_paper27", "seeds3to5_rooms27"))
LAPS = 20  # loop laps per repetition: 10 loops, once each way
BAR = 17  # 85 % of them
BINS = ("<=60", "60-100", "100-135", ">135")

Key = tuple[int, int]  # (study seed, repetition)


def outcomes(study: str) -> dict[Key, dict[tuple, bool]]:
    """Each repetition's loop laps in a study's results, (loop, direction, trial) -> success
    (``room_measures.loop_laps`` per seed)."""
    out: dict[Key, dict[tuple, bool]] = {}
    for folder in sorted((RESULTS / study).glob("*/seed*")):
        seed = int(folder.name.removeprefix("seed"))
        for (repetition, *lap), success in loop_laps(folder).items():
            out.setdefault((seed, repetition), {})[tuple(lap)] = success
    return out


def at_least(n: int, p: float, k: int) -> float:
    """P(X >= k) for X ~ Binomial(n, p)."""
    return sum(math.comb(n, j) * p**j * (1 - p) ** (n - j) for j in range(k, n + 1))


def main() -> None:
    lines = [
        "# Every room at 85 %: the same repetitions without their rooms",
        "",
        "Round 27's winner on the test split, each repetition (study seed, repetition) in the"
        " paper world and in a room of its own, with the same demonstration seeds, trial seeds"
        " and ten test loops (`every_room.py`). A repetition is at the bar with at least"
        f" {BAR} of its {LAPS} loop laps.",
        "",
        "| seeds | repetitions paired | at the bar: paper world | rooms | both | paper only |"
        " rooms only | neither | expected at the pooled rate: paper / rooms |"
        " Spearman, paper vs room laps |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    lost: dict[str, Counter[str]] = {"paper": Counter(), "rooms": Counter()}
    laps_in: dict[str, Counter[str]] = {"paper": Counter(), "rooms": Counter()}
    short: dict[str, Counter[str]] = {"paper": Counter(), "rooms": Counter()}
    facts: dict[str, str] = {}
    for paper_study, rooms_study in PAIRS:
        paper, rooms = outcomes(paper_study), outcomes(rooms_study)
        keys = sorted(
            k
            for k in paper.keys() & rooms.keys()
            if {lap[0] for lap in paper[k]} == {lap[0] for lap in rooms[k]}
        )
        x = np.array([sum(paper[k].values()) for k in keys])
        y = np.array([sum(rooms[k].values()) for k in keys])
        p_paper, p_rooms = x.sum() / (LAPS * len(keys)), y.sum() / (LAPS * len(keys))
        expected = (
            f"{len(keys) * at_least(LAPS, p_paper, BAR):.1f} /"
            f" {len(keys) * at_least(LAPS, p_rooms, BAR):.1f}"
        )
        a, b = x >= BAR, y >= BAR
        seeds = sorted({k[0] for k in keys})
        lines.append(
            f"| {seeds[0]}–{seeds[-1]} | {len(keys)} | {int(a.sum())} | {int(b.sum())} |"
            f" {int((a & b).sum())} | {int((a & ~b).sum())} | {int((~a & b).sum())} |"
            f" {int((~a & ~b).sum())} | {expected} | {spearman(x, y):+.2f} |"
        )
        for world, laps, at_bar in (("paper", paper, a), ("rooms", rooms, b)):
            for key, ok in zip(keys, at_bar, strict=True):
                for (loop, *_), success in laps[key].items():
                    if loop not in facts:
                        facts[loop] = turn_bin(loop_facts(loop)[0])
                    label = facts[loop]
                    laps_in[world][label] += 1
                    if not success:
                        lost[world][label] += 1
                        if not ok:
                            short[world][label] += 1
    lines += [
        "",
        "Laps lost by the loop's sharpest turn (degrees), all repetitions, and of them those lost"
        " by repetitions under the bar:",
        "",
        "| world | " + " | ".join(BINS) + " | all |",
        "|---|" + "---|" * (len(BINS) + 1),
    ]
    for world in ("paper", "rooms"):
        cells = [
            f"{lost[world][b]} of {laps_in[world][b]} ({short[world][b]} under the bar)"
            for b in BINS
        ]
        total = sum(lost[world].values())
        lines.append(
            f"| {world} | " + " | ".join(cells) + f" | {total} ({sum(short[world].values())}) |"
        )
    write_page(RESULTS / "every_room.md", lines)


if __name__ == "__main__":
    main()
