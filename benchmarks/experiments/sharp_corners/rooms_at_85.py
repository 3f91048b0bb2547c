"""Issue 41's bar, room by room: how many kept rooms lap at least 85 % of their loop laps, for
the map-rule runs of parts 8-49 and the learners beside them (committed results only; it chooses
nothing).

    .venv/bin/python benchmarks/experiments/sharp_corners/rooms_at_85.py

Prints, per run and study seed, the rooms at 85 % and every room's lapped loop laps (of 20).
A repetition is a room: each is taught and driven in its own room (``room = "per_repetition"``).
"""

from __future__ import annotations

import sys
from collections import Counter
from pathlib import Path

HERE = Path(__file__).resolve().parent
EXPERIMENTS = HERE.parent
sys.path.insert(0, str(EXPERIMENTS / "human_goal"))

from room_measures import loop_laps  # noqa: E402

ORACLE = HERE / "results" / "oracle_visited"
ROUNDS = EXPERIMENTS / "human_goal"
RUNS = {
    "the map rule as it is": ROUNDS / "round27/results/rules_balance/map-rule",
    "the map rule, the track's visited felt (part 8)": ORACLE / "rooms/map-rule",
    "the map rule, unhide (part 10)": ORACLE / "rooms_unhide/map-rule",
    "the map rule, cover (part 10)": ORACLE / "rooms_cover/map-rule",
    "the map rule, centreline (part 9)": ORACLE / "rooms_centreline/map-rule",
    "the map rule, path_and_centreline (part 11)": ORACLE / "rooms_path_and_centreline/map-rule",
    "the map rule, cover from 0.3 m behind (part 12)": ORACLE / "rooms_cover_from_30cm/map-rule",
    "the map rule, dead ends left out (part 13)": ORACLE / "rooms_dead_ends/map-rule",
    "the map rule, the whole tip left out too (part 14)": ORACLE / "rooms_whole_tip/map-rule",
    "the map rule, blank where the side's strip ends beside felt (part 15)": ORACLE
    / "rooms_overlap/map-rule",
    "the map rule, blank where the side's strip ends and the map disagrees (part 15)": ORACLE
    / "rooms_contra/map-rule",
    "the map rule, overlap or contra (part 17)": ORACLE / "rooms_overlap_or_contra/map-rule",
    "the map rule, blank at frames drawn by chance (part 16, null_1)": ORACLE
    / "rooms_null_1/map-rule",
    "the map rule, blank at frames drawn by chance (part 16, null_2)": ORACLE
    / "rooms_null_2/map-rule",
    "the map rule, judged with a 0.6 m reversal margin (part 18)": HERE
    / "results/margins/rooms_0.6/map-rule",
    "the map rule, judged with a 1.0 m reversal margin (part 18)": HERE
    / "results/margins/rooms_1.0/map-rule",
    "the map rule, no turning back along the leg just taken (part 19)": ORACLE
    / "rooms_turned_60/map-rule",
    "the map rule, no driving back along the strip's other edge (part 20)": ORACLE
    / "rooms_retrace_side/map-rule",
    "the map rule, no picture links (part 22)": HERE
    / "results/margins/rooms_no_picture_links/map-rule",
    "the map rule, strip links of 0.1 m (part 22)": HERE
    / "results/margins/rooms_link_0.1/map-rule",
    "the map rule, read for foreign felt (part 23)": HERE
    / "results/margins/rooms_own_strip/map-rule",
    "the map rule, links of 0.1 m and no picture links (part 24)": HERE
    / "results/margins/rooms_links_0.1_no_picture/map-rule",
    "the map rule, links of 0.12 m and no picture links (part 24)": HERE
    / "results/margins/rooms_links_0.12_no_picture/map-rule",
    "the map rule, the true felt at the regions' centres (part 25)": HERE
    / "results/margins/rooms_true_felt/map-rule",
    "the map rule, fresh felt in sight along felt (part 26)": HERE
    / "results/margins/rooms_felt_sight/map-rule",
    "the map rule, fresh sight as the product has it (part 27, a)": ORACLE / "rooms_sight/map-rule",
    "the map rule, fresh sight, cover from 0.3 m behind (part 27, b)": ORACLE
    / "rooms_sight_cover_from_30cm/map-rule",
    "the map rule, fresh sight, the tip network at 0.5 (part 28)": HERE
    / "results/tip_classifier/rooms/map-rule",
    "the map rule, fresh sight, the tip judged by decision (part 29)": HERE
    / "results/tip_classifier/rooms_decisions/map-rule",
    "the map rule, fresh sight, the tip judged by the oracle's commands (part 30)": HERE
    / "results/tip_classifier/rooms_commands/map-rule",
    "the map rule, fresh sight, the strip-end turn where the network agrees (part 33)": HERE
    / "results/tip_classifier/rooms_gated/map-rule",
    "the map rule, fresh sight, the strip-end turn at 0.45 m (part 34)": ORACLE
    / "rooms_end_blank_0.45/map-rule",
    "the map rule, fresh sight, the strip-end turn at 0.6 m (part 34)": ORACLE
    / "rooms_end_blank_0.6/map-rule",
    "the map rule, fresh sight, felt behind on the branch side (part 35)": ORACLE
    / "rooms_side_behind_0.35/map-rule",
    "the map rule, fresh sight, the path as places (part 36)": ORACLE
    / "rooms_path_places/map-rule",
    "the map rule, fresh sight, places behind at the start only (part 36)": ORACLE
    / "rooms_start_behind/map-rule",
    "the map rule, fresh sight, visited only along felt (part 37, a)": ORACLE
    / "rooms_along_felt/map-rule",
    "the map rule, fresh sight, visited along felt, the path as places (part 37, b)": ORACLE
    / "rooms_along_felt_places/map-rule",
    "the map rule, fresh sight, the path as places, forgotten while blank (part 38)": ORACLE
    / "rooms_places_forget_blank/map-rule",
    "the map rule, fresh sight, the path as places, narrow while blank (part 39)": ORACLE
    / "rooms_places_blank_radius/map-rule",
    "the map rule, fresh sight, along felt over two squares, the path as places (part 40)": ORACLE
    / "rooms_along_felt_run2/map-rule",
    "the map rule, fresh sight, each place visits its strip's measured width (part 41)": ORACLE
    / "rooms_strip_band/map-rule",
    "the map rule, fresh sight, the strip's band over more of the map, with fade (part 42)": ORACLE
    / "rooms_strip_band_fade/map-rule",
    "the map rule, fresh sight, a corner's tip passed by, by the rover's motion (part 44)": ORACLE
    / "rooms_tip_ahead/map-rule",
    "the map rule, fresh sight, part 44's corridor from every stretch (part 46)": ORACLE
    / "rooms_tip_every_stretch/map-rule",
    "the map rule, fresh sight, part 13's dead ends left out (part 48)": ORACLE
    / "rooms_sight_dead_ends/map-rule",
    "the map rule, fresh sight, the tip's corridor laid when the map goes blank (part 49)": ORACLE
    / "rooms_tip_on_blank/map-rule",
    "the learner, round 27's winner": ROUNDS
    / "round27/results/balance/rooms.round20+visual+balance",
    "the learner, round 31 (strip)": ROUNDS / "round31/results/strip/rooms.round27+strip",
    "the learner, round 32 (path_and_centreline)": ROUNDS
    / "round32/results/centreline/rooms.round27+centreline",
    "the learner, round 33 (fresh_sight_m)": ROUNDS / "round33/results/sight/rooms.round27+sight",
    "the learner, round 33, cover from 0.3 m behind (part 27, c)": ORACLE
    / "learner_sight_cover_from_30cm/rooms.round27+sight",
}
BAR = 0.85


def main() -> None:
    print("| run | seed | rooms at 85 % | each room's loop laps |")
    print("|---|---|---|---|")
    for name, folder in RUNS.items():
        if not folder.is_dir():
            print(f"| {name} | – | not run | – |")
            continue
        for seed in sorted(p.name for p in folder.iterdir() if p.is_dir()):
            lapped: Counter[int] = Counter()
            laps: Counter[int] = Counter()
            for (repetition, *_), success in loop_laps(folder / seed).items():
                lapped[repetition] += success
                laps[repetition] += 1
            at_bar = sum(lapped[r] >= BAR * laps[r] for r in laps)
            rooms = ", ".join(f"{lapped[r]}/{laps[r]}" for r in sorted(laps))
            print(f"| {name} | {seed} | {at_bar} of {len(laps)} | {rooms} |")


if __name__ == "__main__":
    main()
