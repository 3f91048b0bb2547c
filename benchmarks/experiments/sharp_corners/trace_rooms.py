"""Part 69 of ``README.md``: ``hairpin_trace.py --loops-from`` records read as a round reads its
rooms: each record's loop laps lapped, by the loop's sharpest turn, the rooms (seed, repetition)
at 85 % of their laps, and lap by lap against the first record (won, lost, and where).

    .venv/bin/python benchmarks/experiments/sharp_corners/trace_rooms.py benchmarks/experiments/sharp_corners/results/tip_cover/rooms_own.json benchmarks/experiments/sharp_corners/results/tip_cover/rooms_tip.json

Reads the ``.json`` records only; it chooses nothing.
"""

from __future__ import annotations

import argparse
import collections
import json
import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from hairpin_trace import hairpin  # noqa: E402

from lfd_track.world.track import load_track  # noqa: E402

#: [deg] the bands of a loop's sharpest turn (as the study tables count them)
BANDS = ((0.0, 60.0), (60.0, 100.0), (100.0, 135.0), (135.0, 180.0))
#: a room is at the bar with this share of its laps
BAR = 0.85


def band(turn: float) -> str:
    """The band name of a sharpest turn ``turn`` [deg]."""
    for low, high in BANDS:
        if turn <= high:
            return f"{low:g}-{high:g}" if low else f"<={high:g}"
    return f">{BANDS[-1][1]:g}"


def load(path: str) -> dict[tuple[int, int, str, str], bool]:
    """A record's laps: (seed, repetition, track, direction) -> lapped."""
    try:
        laps = json.loads(Path(path).read_text(encoding="utf-8"))
        return {
            (lap["seed"], lap["repetition"], lap["track"], lap["direction"]): bool(lap["success"])
            for lap in laps
        }
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise SystemExit(f"{path}: not a hairpin_trace.py record ({exc})") from None


def by_room(run: dict[tuple[int, int, str, str], bool]) -> dict[tuple[int, int], list[int]]:
    """A record's laps per room (seed, repetition): [lapped, driven]."""
    rooms: dict[tuple[int, int], list[int]] = collections.defaultdict(lambda: [0, 0])
    for key, lapped in run.items():
        rooms[key[:2]][0] += lapped
        rooms[key[:2]][1] += 1
    return rooms


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "records", nargs="+", help="hairpin_trace.py .json records; the first is read against"
    )
    args = parser.parse_args()
    runs = [load(path) for path in args.records]
    keys = set(runs[0])
    for path, run in zip(args.records, runs, strict=True):
        if set(run) != keys:
            raise SystemExit(f"{path}: not the first record's laps")
    turns: dict[str, float] = {}
    for _, _, track, _ in keys:
        if track not in turns:
            turns[track] = math.degrees(abs(hairpin(load_track(track))[2]))
    names = [band(t) for t in (0.0, 80.0, 120.0, 150.0)]
    print("| record | laps | " + " | ".join(names) + " | rooms at 85 % | won | lost |")
    print("|---|---|" + "---|" * len(names) + "---|---|---|")
    first = runs[0]
    for path, run in zip(args.records, runs, strict=True):
        by_band: dict[str, list[int]] = collections.defaultdict(lambda: [0, 0])
        for key, lapped in run.items():
            by_band[band(turns[key[2]])][0] += lapped
            by_band[band(turns[key[2]])][1] += 1
        rooms = by_room(run)
        at_bar = sum(1 for done, all_ in rooms.values() if done >= BAR * all_)
        won = sum(1 for key, lapped in run.items() if lapped and not first[key])
        lost = sum(1 for key, lapped in run.items() if not lapped and first[key])
        cells = " | ".join(f"{by_band[n][0]}/{by_band[n][1]}" for n in names)
        print(
            f"| `{Path(path).name}` | {sum(run.values())}/{len(run)} | {cells} |"
            f" {at_bar} of {len(rooms)} | {won} | {lost} |"
        )
    for path, run in zip(args.records[1:], runs[1:], strict=True):
        changed = sorted(key for key in keys if run[key] != first[key])
        print(f"\n`{Path(path).name}` against `{Path(args.records[0]).name}`:")
        for key in changed:
            seed, repetition, track, direction = key
            what = "won" if run[key] else "lost"
            print(
                f"- {what}: room {seed}/{repetition}, {track} {direction}, {turns[track]:.1f} deg"
            )
        low = [
            f"{s}/{r} ({done} of {all_})"
            for (s, r), (done, all_) in sorted(by_room(run).items())
            if done < BAR * all_
        ]
        print(f"- rooms under the bar: {', '.join(low) or 'none'}")


if __name__ == "__main__":
    main()
