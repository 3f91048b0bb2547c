"""Where the fresh felt lies that the track puts behind the rover, against the map's path (part
43 of ``README.md``).

Drives the map rule exactly as ``path_places.py`` does (its options and ``rules.py``'s arguments
are passed on; with none of its options the map is the map as it is, part 27 (a)) and, at every
frame, carries the map's fresh felt to the floor by the rover's true pose and asks the track, as
part 12's oracle does, which of it lies 0.3 m or more of track behind the rover (``behind``).
Each behind point is placed against the map's path, read as a line through its places from the
oldest to the rover's axle (places the rover stood on twice counted once): **beyond the path's
end** (it projects past the axle along the last stretch driven: a sharp corner's tip, felt the
rover turned before reaching), **before its start**, or **beside it**, within the map's disc
(0.35 m), its fade (0.35–0.65 m) or further. The weights are summed over every frame, and again
over the frames the behind felt draws (half or more of the frame's fresh weight), with how many
of those frames follow a frame whose map held no fresh felt. The map's decisions are not
changed; the track is read, never used.

    .venv/bin/python benchmarks/experiments/sharp_corners/where_fresh.py --tally benchmarks/experiments/sharp_corners/results/oracle_visited/where_fresh/as_is.json --study benchmarks/experiments/human_goal/round27/balance.toml --condition rooms.round20+visual+balance --rule map-rule --map branch_side=true --map branch_window=commands --map motion=visual --map colour_balance=safe_box --map fresh_sight_m=0.05 --out /tmp/where_fresh --workers 2
    .venv/bin/python benchmarks/experiments/sharp_corners/where_fresh.py --show benchmarks/experiments/sharp_corners/results/oracle_visited/where_fresh/as_is.json
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import oracle_visited  # noqa: E402
import path_places  # noqa: E402

#: [m] felt whose centreline lies this much track behind the rover or more is behind (part 12)
BEHIND_M = 0.3
#: [m] the map's disc round each place and the end of its fade (``path_radius_m``, plus
#: ``visited_fade_m``), for the bins beside the path
DISC_M, FADE_END_M = 0.35, 0.65
#: where a behind point lies against the path, in the order the table lists them
PLACES = (
    "beyond the path's end",
    "before its start",
    "beside, within 0.35 m",
    "beside, 0.35-0.65 m",
    "beside, further",
)
TALLY: dict[str, Any] = {"file": None}


def against_path(points: np.ndarray, path: np.ndarray) -> np.ndarray:
    """(N,) int: the index into :data:`PLACES` of where each of ``points`` (N, 2) lies against
    the line through ``path``'s places (M, 2) and the axle (the origin)."""
    line = np.vstack([path, np.zeros((1, 2))])
    keep = np.ones(len(line), dtype=bool)
    keep[1:] = np.hypot(*(line[1:] - line[:-1]).T) > 1e-6
    line = line[keep]
    if len(line) == 1:  # the axle alone
        dist = np.hypot(points[:, 0], points[:, 1])
        return np.digitize(dist, [DISC_M, FADE_END_M]) + 2
    start, seg = line[:-1], line[1:] - line[:-1]  # (S, 2)
    rel = points[:, None, :] - start[None, :, :]  # (N, S, 2)
    t = (rel * seg[None]).sum(axis=2) / (seg * seg).sum(axis=1)[None]
    foot = start[None] + np.clip(t, 0.0, 1.0)[..., None] * seg[None]
    dist = np.hypot(*(points[:, None, :] - foot).transpose(2, 0, 1))  # (N, S)
    nearest = dist.argmin(axis=1)
    rows = np.arange(len(points))
    where = np.digitize(dist[rows, nearest], [DISC_M, FADE_END_M]) + 2
    where[(nearest == len(seg) - 1) & (t[rows, nearest] > 1.0)] = 0
    where[(nearest == 0) & (t[rows, nearest] < 0.0)] = 1
    return where


def recording(base: type[path_places.PlacesMemory]) -> type[path_places.PlacesMemory]:
    """``base``'s map, tallying where its behind fresh felt lies at every frame."""

    class Recording(base):  # type: ignore[valid-type, misc]
        def reset(self) -> None:
            super().reset()
            self._last_weights = np.zeros(0)

        def _fresh(self, near: np.ndarray, ahead: np.ndarray) -> np.ndarray:
            weights = super()._fresh(near, ahead)
            self._last_weights = weights
            return weights

        def see(self, values: np.ndarray, levels: tuple[float, float] | None = None) -> None:
            was_blank = len(self._path) > 0 and float(self._inputs[1]) <= 0.0
            self._last_weights = np.zeros(0)
            super().see(values, levels)
            tally(self, self._last_weights, was_blank)

    return Recording


def tally(memory: path_places.PlacesMemory, weights: np.ndarray, was_blank: bool) -> None:
    """Add this frame's behind fresh felt to the tally (``--tally FILE``, per worker)."""
    now = oracle_visited.NOW
    chosen = np.flatnonzero(weights > 0.0)
    if now["track"] is None or not len(chosen):
        return
    floor = oracle_visited.to_floor(memory._points[chosen], now["pose"])
    behind = ~oracle_visited.track_ahead(now["track"], floor, now["progress_m"], BEHIND_M)
    state = TALLY.setdefault(
        "sums",
        {
            "frames": 0,
            "fresh": 0.0,
            "behind": [0.0] * len(PLACES),
            "drawn_frames": 0,
            "drawn_after_blank": 0,
            "drawn": [0.0] * len(PLACES),
        },
    )
    state["frames"] += 1
    total = float(weights[chosen].sum())
    state["fresh"] += total
    if behind.any():
        where = against_path(memory._points[chosen[behind]], memory._path)
        mass = np.bincount(where, weights=weights[chosen[behind]], minlength=len(PLACES))
        state["behind"] = [a + float(b) for a, b in zip(state["behind"], mass, strict=True)]
        if float(mass.sum()) >= 0.5 * total:
            state["drawn_frames"] += 1
            state["drawn_after_blank"] += int(was_blank)
            state["drawn"] = [a + float(b) for a, b in zip(state["drawn"], mass, strict=True)]
    with open(f"{TALLY['file']}.{os.getpid()}", "w") as out:
        json.dump(state, out)


def show(path: Path) -> str:
    """The tally ``path`` as a Markdown table."""
    sums = json.loads(path.read_text())
    lines = [
        f"{sums['frames']} frames with fresh felt; behind (0.3 m of track or more) "
        f"{sum(sums['behind']) / sums['fresh']:.1%} of their fresh weight; "
        f"{sums['drawn_frames']} frames drawn behind (half their fresh weight or more), "
        f"{sums['drawn_after_blank']} of them after a blank frame",
        "",
        "| where the behind felt lies | share of behind weight, all frames | ... in frames drawn behind |",
        "|---|---|---|",
    ]
    every, drawn = sum(sums["behind"]) or 1.0, sum(sums["drawn"]) or 1.0
    for name, a, b in zip(PLACES, sums["behind"], sums["drawn"], strict=True):
        lines.append(f"| {name} | {a / every:.1%} | {b / drawn:.1%} |")
    return "\n".join(lines) + "\n"


def main() -> None:
    if "--show" in sys.argv:
        print(show(Path(sys.argv[sys.argv.index("--show") + 1])), end="")
        return
    at = sys.argv.index("--tally")
    out = TALLY["file"] = Path(sys.argv[at + 1])
    del sys.argv[at : at + 2]
    out.parent.mkdir(parents=True, exist_ok=True)
    for old in out.parent.glob(f"{out.name}.*"):
        old.unlink()
    oracle_visited.main(recording(path_places.memory_from_args()))
    total: dict[str, Any] = {}
    for part in sorted(out.parent.glob(f"{out.name}.*")):
        sums = json.loads(part.read_text())
        for key, value in sums.items():
            if isinstance(value, list):
                total[key] = [
                    a + b for a, b in zip(total.get(key, [0.0] * len(value)), value, strict=True)
                ]
            else:
                total[key] = total.get(key, 0) + value
        part.unlink()
    out.write_text(json.dumps(total, indent=1) + "\n")
    print(show(out), end="")


if __name__ == "__main__":
    main()
