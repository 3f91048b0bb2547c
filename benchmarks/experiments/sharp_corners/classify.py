"""Classify each failed procedural-loop lap at its failing corner, from the traces ``run_rules.py``
keeps (pose after every command, the command, the map's three inputs).

The failing corner is whichever of the first corner not negotiated and the last one negotiated
lies nearer the rover's last position (a lap that turns back after negotiating a corner fails
there). With its
vertex V, signed turn T and the centreline's incoming direction ``a_in`` (the loop rebuilt from
its name, ``lfd_track.world.track.loop_track``), from the first command within ``APPROACH_M``
of V to the end of the lap:

* ``turned`` = the rover's heading change relative to ``a_in``, toward T, as a fraction of |T|
  (1 = lined up with the outgoing strip);
* ``first pivot``: whether the first pivot once the rover was within ``CLOSE_M`` of V went toward
  the turn or away, and the
  map's fresh-felt bearing when it was chosen (toward the turn positive; ``blank``: no fresh
  felt, the rule pivots toward the side it last saw felt on);
* ``pivots at V``: pivots toward / away while within ``CLOSE_M`` of V;
* ``past V``: how far beyond V along ``a_in`` the rover's pivot centre was at its first pivot
  toward the turn (negative = before V) [m];
* ``blank``: the fraction of those commands chosen while the map held no fresh felt.

Classes, in this order: ``not reached`` (the corner never came within 0.30 m of progress);
``far from it`` (the lap ended more than ``FAR_M`` from V: it left the corner behind, e.g. onto
another part of the loop); ``spun in place`` (the heading turned more than a full turn, either
way, from the approach to the end);
``wrong way`` (turned < -0.25); ``straight past`` (turned < 0.25); ``under-turned`` (turned
< 0.75); ``turned, then lost`` (turned <= 1.5); ``over-turned`` (turned > 1.5).

    .venv/bin/python benchmarks/experiments/sharp_corners/classify.py results/paper [results/wide ...]

Writes ``failures.json`` and ``failures.md`` in each results folder (map rule only unless
``--rule``).
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np

from lfd_track.world.loops import sharpest_turn_deg, turn_bin
from lfd_track.world.track import loop_track

APPROACH_M = 0.6
FAR_M = 1.0  # a lap ending further than this from the corner's vertex failed away from it [m]
CLOSE_M = 0.3  # "at the vertex": the rover's pivot centre within this of V [m]
BEARING_RANGE_DEG = 30.0  # the shipped map's bearing input range (FreshFeltConfig)
CLASSES = (
    "not reached",
    "far from it",
    "spun in place",
    "wrong way",
    "straight past",
    "under-turned",
    "turned, then lost",
    "over-turned",
)


def wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


def classify_lap(lap: dict) -> dict:
    _, split, index = lap["track"].split(":")
    track = loop_track(split, int(index), reverse=lap["direction"] == "cw")
    assert [c.label for c in track.corners] == [c[0] for c in lap["corners"]]
    steps = np.asarray(lap["steps"], dtype=float)  # x, y, theta, command, bearing, amount, dist
    order, done = lap["corner_order"], lap["corners_negotiated"]
    candidates = [c for c in order if c not in done][:1] + done[-1:]
    by_label = {c.label: c for c in track.corners}
    end = steps[-1, :2]
    failing = min(
        candidates, key=lambda c: np.linalg.norm(track.vertices[by_label[c].vertex] - end)
    )
    corner = by_label[failing]
    verts = track.vertices
    v = verts[corner.vertex]
    prev = verts[corner.vertex - 1]
    u_in = (v - prev) / np.linalg.norm(v - prev)
    a_in = math.atan2(u_in[1], u_in[0])
    turn = math.radians(corner.turn_deg)
    sign = 1.0 if turn > 0 else -1.0
    xy, theta, cmd, amount = steps[:, :2], steps[:, 2], steps[:, 3].astype(int), steps[:, 5]
    dist = np.linalg.norm(xy - v, axis=1)
    near = np.nonzero(dist <= APPROACH_M)[0]
    row = {
        "track": lap["track"],
        "direction": lap["direction"],
        "failure": lap["failure"],
        "corner": failing,
        "corner_turn_deg": round(abs(corner.turn_deg), 1),
        "sharpest_deg": round(sharpest_turn_deg(track), 1),
        "bin": turn_bin(sharpest_turn_deg(track)),
        "width_m": round(track.width_m, 3),
        "corners_negotiated_before": len(lap["corners_negotiated"]),
        "negotiated": failing in done,
        "end_from_v_m": round(float(np.linalg.norm(end - v)), 2),
    }
    if failing not in lap["corners_reached"] or not len(near):  # failed on the way to it
        row.update(
            cls="not reached",
            turned=None,
            first_pivot=None,
            pivots_at_v=None,
            first_pivot_bearing_deg=None,
            past_v_m=None,
            blank=None,
        )
        return row
    k = int(near[0])
    # heading before the first considered command = theta after the previous one
    start = theta[k - 1] if k > 0 else theta[k]
    dtheta = np.diff(np.concatenate([[start], theta[k:]]))
    dtheta = np.array([wrap(d) for d in dtheta])
    total = wrap(start - a_in) + float(dtheta.sum())
    turned = total * sign / abs(turn)
    toward = 1 if sign > 0 else 2
    close = np.nonzero(dist <= CLOSE_M)[0]
    k2 = int(close[0]) if len(close) else k
    pivots = [(i, c) for i, c in enumerate(cmd[k2:], start=k2) if c in (1, 2)]
    at_v = cmd[k2:][dist[k2:] <= CLOSE_M]
    pivots_at_v = f"{int(np.sum(at_v == toward))}/{int(np.sum(at_v == 3 - toward))}"
    first = None if not pivots else ("toward" if pivots[0][1] == toward else "away")
    # the map's bearing when the first pivot was chosen, toward the turn positive [deg]
    first_bearing = None
    if pivots:
        i = pivots[0][0]
        raw = (2.0 * steps[i, 4] - 1.0) * BEARING_RANGE_DEG
        first_bearing = round(raw * sign, 1) if steps[i, 5] > 0 else "blank"
    first_toward = next((i for i, c in pivots if c == toward), None)
    past = None
    if first_toward is not None:
        pos = xy[first_toward - 1] if first_toward > 0 else xy[first_toward]
        past = round(float((pos - v) @ u_in), 3)
    blank = float(np.mean(amount[k:] <= 0.0))
    if float(np.linalg.norm(end - v)) > FAR_M:
        cls = "far from it"
    elif abs(total) > 2 * math.pi:
        cls = "spun in place"
    elif turned < -0.25:
        cls = "wrong way"
    elif turned < 0.25:
        cls = "straight past"
    elif turned < 0.75:
        cls = "under-turned"
    elif turned <= 1.5:
        cls = "turned, then lost"
    else:
        cls = "over-turned"
    row.update(
        cls=cls,
        turned=round(turned, 2),
        first_pivot=first,
        pivots_at_v=pivots_at_v,
        first_pivot_bearing_deg=first_bearing,
        past_v_m=past,
        blank=round(blank, 2),
        commands_from_approach=int(len(cmd) - k),
    )
    return row


def corners_over(lap: dict, min_turn_deg: float = 100.0) -> list[dict]:
    """Every corner of ``lap`` turning more than ``min_turn_deg`` that the rover came within
    ``CLOSE_M`` of: whether it was negotiated, whether the map held fresh felt when the rover
    first came that close, and the first pivot from there (toward / away from the turn)."""
    _, split, index = lap["track"].split(":")
    track = loop_track(split, int(index), reverse=lap["direction"] == "cw")
    steps = np.asarray(lap["steps"], dtype=float)
    rows = []
    for corner in track.corners:
        if abs(corner.turn_deg) <= min_turn_deg:
            continue
        v = track.vertices[corner.vertex]
        close = np.nonzero(np.linalg.norm(steps[:, :2] - v, axis=1) <= CLOSE_M)[0]
        if not len(close):
            continue
        k = int(close[0])
        toward = 1 if corner.turn_deg > 0 else 2
        pivots = [int(c) for c in steps[k:, 3] if int(c) in (1, 2)]
        rows.append(
            {
                "negotiated": corner.label in lap["corners_negotiated"],
                "blank_at_v": bool(steps[k, 5] <= 0.0),
                "first_pivot": None
                if not pivots
                else ("toward" if pivots[0] == toward else "away"),
            }
        )
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("folders", nargs="+", type=Path)
    parser.add_argument("--rule", default="map-rule")
    args = parser.parse_args()
    for folder in args.folders:
        laps = []
        for path in sorted((folder / "traces").glob(f"{args.rule}_rep*.json")):
            rep = int(path.stem.rsplit("rep", 1)[1])
            laps += [dict(lap, repetition=rep) for lap in json.loads(path.read_text())]
        failed = [lap for lap in laps if not lap["success"]]
        rows = [dict(classify_lap(lap), repetition=lap["repetition"]) for lap in failed]
        (folder / f"failures_{args.rule}.json").write_text(
            json.dumps(rows, indent=1) + "\n", encoding="utf-8"
        )
        lines = [
            f"# Failed {args.rule} laps in {folder.name}: {len(failed)} of {len(laps)}",
            "",
            "| rep | loop | dir | bin | failing corner (turn) | failure | class | turned"
            " | first pivot at V (map bearing, + = toward) | pivots at V toward/away | past V [m] | blank | end from V [m] | width [m] |",
            "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
        ]
        for r in sorted(rows, key=lambda r: -r["corner_turn_deg"]):
            lines.append(
                f"| {r['repetition']} | {r['track']} | {r['direction']} | {r['bin']}"
                f" | {r['corner']} ({r['corner_turn_deg']:.0f}°) | {r['failure']} | {r['cls']}"
                f" | {r['turned']} | {r['first_pivot']} ({r['first_pivot_bearing_deg']})"
                f" | {r['pivots_at_v']} | {r['past_v_m']} | {r['blank']}"
                f" | {r['end_from_v_m']} | {r['width_m']} |"
            )
        counts = {c: sum(r["cls"] == c for r in rows) for c in CLASSES}
        lines += ["", "| class | laps |", "|---|---|"]
        lines += [f"| {c} | {n} |" for c, n in counts.items()]
        sharp = [c for lap in laps for c in corners_over(lap)]
        lines += [
            "",
            f"Every corner over 100° the rover came within {CLOSE_M} m of ({len(sharp)}):"
            " the map's state there and the first pivot from there",
            "",
            "| corner | map blank at V | first pivot toward | first pivot away | no pivot |",
            "|---|---|---|---|---|",
        ]
        for ok in (True, False):
            mine = [c for c in sharp if c["negotiated"] == ok]
            lines.append(
                f"| {'negotiated' if ok else 'not negotiated'} ({len(mine)})"
                f" | {sum(c['blank_at_v'] for c in mine)}"
                f" | {sum(c['first_pivot'] == 'toward' for c in mine)}"
                f" | {sum(c['first_pivot'] == 'away' for c in mine)}"
                f" | {sum(c['first_pivot'] is None for c in mine)} |"
            )
        (folder / f"failures_{args.rule}.md").write_text("\n".join(lines) + "\n", encoding="utf-8")
        print("\n".join(lines))


if __name__ == "__main__":
    main()
