"""Part 68 of ``README.md``: the loop laps one room lost, under each condition given.

For each committed condition folder (``--results``, folders of ``seed*/results.json``), the loop
laps of seed ``--seed``'s repetition ``--repetition`` that failed: the loop, the direction, how it
failed and the loop's sharpest turn. Reads committed results only.

    .venv/bin/python benchmarks/experiments/sharp_corners/room_losses.py --seed 100 --repetition 4 --results benchmarks/experiments/human_goal/round41/results/prior/rooms.round39+prior benchmarks/experiments/human_goal/round44/results/edge_cover/rooms.round41+edge_cover
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from hairpin_trace import hairpin  # noqa: E402

from lfd_track.world.track import load_track  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--results", nargs="+", required=True, help="condition folders")
    parser.add_argument("--seed", type=int, required=True)
    parser.add_argument("--repetition", type=int, required=True)
    args = parser.parse_args()
    for folder in args.results:
        path = Path(folder) / f"seed{args.seed}" / "results.json"
        try:
            outcomes = json.loads(path.read_text(encoding="utf-8"))["outcomes"]
        except (OSError, ValueError, KeyError) as exc:
            raise SystemExit(f"{path}: not a study job's results ({exc})") from None
        loops = [
            o
            for o in outcomes
            if o["repetition"] == args.repetition and o["track"].startswith("random:")
        ]
        lost = [o for o in loops if not o["success"]]
        print(f"{folder}: {len(loops) - len(lost)} of {len(loops)} loop laps lapped")
        for o in lost:
            turn = math.degrees(abs(hairpin(load_track(o["track"]))[2]))
            print(f"  {o['track']} {o['direction']}: {o['failure'] or 'timeout'}, {turn:.1f} deg")


if __name__ == "__main__":
    main()
