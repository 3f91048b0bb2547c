"""What the map holds at the frames part 12's oracle changes, beside frames where it does not
(part 15 of ``README.md``).

Reads the maps ``screen.py --frames DIR --sample N`` kept (every frame whose command the oracle
changes, and every N-th frame) and prints, for the frames the oracle changes and for the sampled
frames it keeps where the branch side gives a side and the rover's own strip ends within
``END_M`` ahead (``dead_ends.strip_end_m``): the quartiles of what a robot's map could tell them
by (the fresh felt's mass, bearing and distance; how far ahead the strip ends; the map's points
and their felt beside the rover on the branch side's side), and the share of the fresh felt that
the oracle counts behind (which a robot cannot see).

    .venv/bin/python benchmarks/experiments/sharp_corners/frames.py /tmp/screen_frames

``--paths`` also lists each changed frame's path: how many places it holds and how far back the
farthest lies (part 36).
"""

from __future__ import annotations

import math
import pickle
import sys
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import dead_ends  # noqa: E402

#: [m] the strip's end is looked for up to this far ahead
END_M = 0.8
#: [m] "beside": from BESIDE_X[0] to BESIDE_X[1] along the heading, BESIDE_OFF[0] to
#: BESIDE_OFF[1] off it on the branch side's side
BESIDE_X, BESIDE_OFF = (-0.3, 0.3), (0.3, 0.8)


def measures(frame: dict[str, Any]) -> dict[str, float]:
    """What the frame's map tells (see the module docstring)."""
    points, felt, weights = frame["points"], frame["felt"], frame["weights"]
    fresh = points[frame["chosen"]]
    mass = float(weights.sum())
    centre = (weights[:, None] * fresh).sum(axis=0) / mass if mass > 0 else np.zeros(2)
    end = dead_ends.strip_end_m(points, felt, END_M)
    side = 1.0 if frame["side"] > 0.5 else -1.0
    off = points[:, 1] * side
    beside = (
        (points[:, 0] >= BESIDE_X[0])
        & (points[:, 0] <= BESIDE_X[1])
        & (off >= BESIDE_OFF[0])
        & (off <= BESIDE_OFF[1])
    )
    return {
        "fresh mass": mass,
        "bearing toward the side [deg]": side * math.degrees(math.atan2(centre[1], centre[0])),
        "distance [m]": float(math.hypot(centre[0], centre[1])),
        "strip ends ahead [m]": END_M + 0.05 if end is None else end,
        "points beside": float(beside.sum()),
        "felt beside": float(felt[beside].mean()) if beside.any() else 0.0,
        "share the oracle counts behind": float(weights[frame["behind"]].sum()) / mass
        if mass > 0
        else 0.0,
        "path places": float(len(frame["path"])),
        "path reaches back [m]": float(np.hypot(*frame["path"].T).max())
        if len(frame["path"])
        else 0.0,
    }


def main() -> None:
    frames: list[dict[str, Any]] = []
    for saved in sorted(Path(sys.argv[1]).glob("frames_*.pkl")):
        with open(saved, "rb") as f:  # screen.py appends one record a frame
            while True:
                try:
                    frames.append(pickle.load(f))
                except EOFError:
                    break
    measured = [measures(f) for f in frames]  # once a frame
    changed = [
        m for f, m in zip(frames, measured, strict=True) if f["as_is"] != f["said"]["oracle"]
    ]
    kept = [
        m
        for f, m in zip(frames, measured, strict=True)
        if f["as_is"] == f["said"]["oracle"]
        and f["side"] != 0.5
        and m["strip ends ahead [m]"] <= END_M
    ]
    print(f"{len(frames)} frames: {len(changed)} the oracle changes, {len(kept)} sampled ones it")
    print(f"keeps with a side given and the strip ending within {END_M} m (quartiles)\n")
    print("| measure | frames the oracle changes | frames it keeps |")
    print("|---|---|---|")
    for name in measured[0]:
        cells = []
        for group in (changed, kept):
            values = np.array([m[name] for m in group])
            q = np.percentile(values, [25, 50, 75]) if len(values) else [math.nan] * 3
            cells.append(" / ".join(f"{v:.2f}" for v in q))
        print(f"| {name} | {cells[0]} | {cells[1]} |")
    if "--paths" in sys.argv:  # part 36: each changed frame's path
        print("\n| frame | as it is / the oracle | path places | path reaches back [m] |")
        print("|---|---|---|---|")
        changed_frames = [f for f in frames if f["as_is"] != f["said"]["oracle"]]
        for k, (frame, m) in enumerate(zip(changed_frames, changed, strict=True)):
            said = f"{frame['as_is']} / {frame['said']['oracle']}"
            print(f"| {k} | {said} | {m['path places']:.0f} | {m['path reaches back [m]']:.2f} |")


if __name__ == "__main__":
    main()
