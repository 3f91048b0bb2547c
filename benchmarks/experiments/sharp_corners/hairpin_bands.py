"""Part 68 of ``README.md``: a ``hairpin_trace.py`` record's laps by the loop's sharpest turn.

Reads the ``.json`` beside a ``hairpin_trace.py`` page (run with ``--past 150`` it holds all of
``hairpins.toml``'s laps) and prints the laps lapped with the loops' sharpest turn at 150–155° and
past 155° (part 60's candidate bar reads those two), and the rooms (seed, repetition) at 85 % of
their laps.

    .venv/bin/python benchmarks/experiments/sharp_corners/hairpin_bands.py benchmarks/experiments/sharp_corners/results/hairpin_trace/edge_cover_800.json
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

#: the bands: (name, low, high] [deg]
BANDS = (("150–155°", 150.0, 155.0), ("past 155°", 155.0, 180.0))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("record", help="a hairpin_trace.py .json record")
    args = parser.parse_args()
    path = Path(args.record)
    try:
        laps = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise SystemExit(f"{path}: not a hairpin_trace.py record ({exc})") from None
    turns: dict[str, float] = {}
    lapped: collections.Counter[str] = collections.Counter()
    driven: collections.Counter[str] = collections.Counter()
    rooms: dict[tuple[int, int], list[bool]] = collections.defaultdict(list)
    for lap in laps:
        name = lap["track"]
        if name not in turns:
            turns[name] = math.degrees(abs(hairpin(load_track(name))[2]))
        for band, low, high in BANDS:
            if low < turns[name] <= high:
                driven[band] += 1
                lapped[band] += bool(lap["success"])
        rooms[lap["seed"], lap["repetition"]].append(bool(lap["success"]))
    for band, _, _ in BANDS:
        print(f"{band}: {lapped[band]} of {driven[band]} lapped")
    at_bar = sum(sum(done) >= 0.85 * len(done) for done in rooms.values())
    print(f"all: {sum(lap['success'] for lap in laps)} of {len(laps)}; rooms at 85 %: {at_bar}")


if __name__ == "__main__":
    main()
