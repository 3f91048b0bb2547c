"""Where the fresh felt lies that the track puts behind the rover, against the map's path (parts
43, 45 and 47 of ``README.md``).

Drives the map rule exactly as ``path_places.py`` does (its options and ``rules.py``'s arguments
are passed on; with none of its options the map is the map as it is, part 27 (a)) and, at every
frame, carries the map's fresh felt to the floor by the rover's true pose and asks the track, as
part 12's oracle does, which of it lies 0.3 m or more of track behind the rover (``behind``).
Each behind point is placed against the map's path, read as a line through its places from the
oldest to the rover's axle (places the rover stood on twice counted once): **beyond the path's
end** (it projects past the axle along the last stretch driven: felt ahead of wherever the
rover has been), **before its start**, or **beside it**, within the map's disc
(0.35 m), its fade (0.35–0.65 m) or further. The weights are summed over every frame, and again
over the frames the behind felt draws (half or more of the frame's fresh weight), with how many
of those frames follow a frame whose map held no fresh felt. The behind felt beyond the path's
end is binned too (:data:`BEYOND_BINS`): by the rover's turn from its last stretch, how far past
the axle it lies along that stretch and how far from its line, and what share part 44's corridor
would cover (part 45); by how far behind the rover's progress its centreline lies, how far the
rover is from the nearest corner's vertex and that corner's turn (part 47). The map's decisions
are not changed; the track is read, never used.

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

import margins  # noqa: E402
import oracle_visited  # noqa: E402
import path_places  # noqa: E402
import tips  # noqa: E402

#: [m] felt whose centreline lies this much track behind the rover or more is behind (part 12)
BEHIND_M = tips.BEHIND_M
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


def path_line(path: np.ndarray) -> np.ndarray:
    """(L, 2): the map's path (M, 2) and the axle (the origin) as a line, each place the rover
    stood on again and again kept once."""
    line = np.vstack([path, np.zeros((1, 2))])
    keep = np.ones(len(line), dtype=bool)
    keep[1:] = np.hypot(*(line[1:] - line[:-1]).T) > 1e-6
    return line[keep]


def against_path(points: np.ndarray, path: np.ndarray) -> np.ndarray:
    """(N,) int: the index into :data:`PLACES` of where each of ``points`` (N, 2) lies against
    the line through ``path``'s places (M, 2) and the axle (the origin)."""
    line = path_line(path)
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


#: part 45: the felt beyond the path's end, binned by the rover's turn from the last stretch
#: [deg], how far past the axle it lies along that stretch [m] and how far from its line [m]
BEYOND_BINS = {
    "turn": (45.0, 90.0, 135.0),
    "along": (0.3, 0.6, 1.0),
    "across": (0.25, 0.5),
    # part 47: how far behind the rover's progress the felt's centreline lies [m], how far the
    # rover's progress is from the nearest corner's vertex [m], and that corner's turn [deg]
    "track": (1.0, 2.0),
    "vertex": (margins.NEAR_VERTEX_M,),
    "corner": (100.0,),
    # part 50: whether the command just settled was a forward step (1) or a pivot (0), and how
    # long the path's last segment is [m] (a pivot moved by the measured motion leaves a few mm)
    "forward": (0.5,),
    "segment": (0.05,),
}
#: part 44's corridor (``--tip-turn`` 90°, ``--tip-ahead`` 0.6 m), for the share part 45 reads
PART_44 = (90.0, 0.6)
UNITS = {
    "turn": "°",
    "along": " m",
    "across": " m",
    "track": " m",
    "vertex": " m",
    "corner": "°",
    "forward": "",
    "segment": " m",
}
#: bins shown by name rather than by their edges
NAMED = {"forward": ["after a pivot", "after a forward step"]}


def track_behind(track: Any, floor: np.ndarray, progress_m: float) -> np.ndarray:
    """(N,) [m]: how far behind ``progress_m`` the centreline nearest each floor point (N, 2)
    lies along ``track`` (on a loop, taken round the way it is driven)."""
    gap = progress_m - oracle_visited.centreline_at(track, floor)
    return gap % track.length_m if track.closed else gap


def beyond_end(points: np.ndarray, path: np.ndarray) -> dict[str, np.ndarray]:
    """For ``points`` (N, 2) beyond the end of the line through ``path`` and the axle: the
    rover's turn from the last stretch [deg] (one value), and each point's distance past the
    axle along that stretch and from its line [m]."""
    line = path_line(path)
    seg = line[-1] - line[-2]
    unit = seg / np.hypot(*seg)
    turn = abs(np.degrees(np.arctan2(unit[1], unit[0])))  # the rover faces +x
    along = points @ unit  # past the axle (the line's end)
    across = np.abs(unit[0] * points[:, 1] - unit[1] * points[:, 0])
    return {
        "turn": np.full(len(points), turn),
        "along": along,
        "across": across,
        "segment": np.full(len(points), float(np.hypot(*seg))),
    }


def recording(base: type[path_places.PlacesMemory]) -> type[path_places.PlacesMemory]:
    """``base``'s map, tallying where its behind fresh felt lies at every frame."""

    class Recording(base):  # type: ignore[valid-type, misc]
        def reset(self) -> None:
            super().reset()
            self._last_weights = np.zeros(0)
            self._stepped = False  # the command settled last was a forward step

        def _move(self, command: int, measured=None) -> None:  # noqa: ANN001 - PlanarMotion | None
            self._stepped = command == 0
            super()._move(command, measured)

        def _fresh(self, near: np.ndarray, ahead: np.ndarray) -> np.ndarray:
            weights = super()._fresh(near, ahead)
            self._last_weights = weights
            return weights

        def see(self, values: np.ndarray, levels: tuple[float, float] | None = None) -> None:
            was_blank = len(self._path) > 0 and self._blank()
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
        state["behind"] = merged(state["behind"], mass.tolist())
        drawn = float(mass.sum()) >= 0.5 * total
        if drawn:
            state["drawn_frames"] += 1
            state["drawn_after_blank"] += int(was_blank)
            state["drawn"] = merged(state["drawn"], mass.tolist())
        past = where == 0
        if past.any():
            weight = weights[chosen[behind]][past]
            measured = beyond_end(memory._points[chosen[behind]][past], memory._path)
            measured["track"] = track_behind(now["track"], floor[behind][past], now["progress_m"])
            corner = margins.corner_near(now["track"], now["progress_m"])
            measured["vertex"] = np.full(len(weight), abs(corner.get("from_vertex_m", 9.0)))
            measured["corner"] = np.full(len(weight), abs(corner.get("turn_deg", 0.0)))
            measured["forward"] = np.full(len(weight), float(getattr(memory, "_stepped", False)))
            for key in ("beyond", "beyond_drawn") if drawn else ("beyond",):
                bins = state.setdefault(key, {})
                for name, edges in BEYOND_BINS.items():
                    add = np.bincount(
                        np.digitize(measured[name], edges), weights=weight, minlength=len(edges) + 1
                    )
                    bins[name] = merged(bins.get(name), add.tolist())
                turn, ahead = PART_44  # a stand-in: the frame's own line, not the kept corridors
                inside = (
                    (measured["turn"] >= turn)
                    & (measured["along"] <= ahead)
                    & (measured["across"] <= path_places.TIP_HALF_M)
                )
                bins["corridor"] = bins.get("corridor", 0.0) + float(weight[inside].sum())
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
        "| where the behind felt lies | share of behind weight, all frames "
        "| ... in frames drawn behind |",
        "|---|---|---|",
    ]
    every, drawn = sum(sums["behind"]) or 1.0, sum(sums["drawn"]) or 1.0
    for name, a, b in zip(PLACES, sums["behind"], sums["drawn"], strict=True):
        lines.append(f"| {name} | {a / every:.1%} | {b / drawn:.1%} |")
    for key, title in (("beyond", "all frames"), ("beyond_drawn", "frames drawn behind")):
        bins = sums.get(key)
        if not bins:
            continue
        whole = sum(bins["turn"]) or 1.0
        lines += ["", f"Beyond the path's end, {title} (share of its weight):", ""]
        for name, unit in UNITS.items():
            if name not in bins:
                continue
            edges = [0.0, *BEYOND_BINS[name]]
            labels = [f"{a:g}–{b:g}{unit}" for a, b in zip(edges, edges[1:], strict=False)]
            labels.append(f"{edges[-1]:g}{unit} or more")
            labels = NAMED.get(name, labels)
            cells = ", ".join(
                f"{label} {v / whole:.1%}" for label, v in zip(labels, bins[name], strict=True)
            )
            lines.append(f"- {name}: {cells}")
        lines.append(f"- within part 44's corridor: {bins['corridor'] / whole:.1%}")
    return "\n".join(lines) + "\n"


def merged(one: Any, other: Any) -> Any:
    """Two workers' tallies summed: numbers added, lists element by element, dicts by key."""
    if isinstance(other, dict):
        base = one or {}
        return {key: merged(base.get(key), other.get(key)) for key in base.keys() | other.keys()}
    if other is None:
        return one
    if isinstance(other, list):
        return [a + b for a, b in zip(one or [0.0] * len(other), other, strict=True)]
    return (one or 0) + other


def main() -> None:
    if "--show" in sys.argv:
        print(show(Path(sys.argv[sys.argv.index("--show") + 1])), end="")
        return
    out = TALLY["file"] = oracle_visited.worker_file("--tally")
    oracle_visited.main(recording(path_places.memory_from_args()))
    total: dict[str, Any] = {}
    for part in sorted(out.parent.glob(f"{out.name}.*")):
        total = merged(total, json.loads(part.read_text()))
        part.unlink()
    out.write_text(json.dumps(total, indent=1) + "\n")
    print(show(out), end="")


if __name__ == "__main__":
    main()
