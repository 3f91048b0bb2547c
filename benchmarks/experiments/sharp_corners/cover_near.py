"""Part 65 of ``README.md``: part 12's oracle cover, only as far behind as the hairpin's own legs.

Part 64 found that at a hairpin's vertex much of the felt part 12's oracle covers (the map's fresh
felt whose centreline the track puts 0.3 m or more behind the rover, up to half the loop) lies on
other legs of the loop in sight of the vertex, not on the incoming strip. :class:`CoverNearMemory`
is that oracle with its cover cut at :data:`COVER_TO_M` behind the rover along the track: felt
further behind (other legs) keeps the map's own state. It is an oracle (it reads the track), a
controlled experiment on which felt carries the oracle's hairpin laps, not a design.

    .venv/bin/python benchmarks/experiments/sharp_corners/hairpin_trace.py --oracle --cover-to 2.0 --study benchmarks/experiments/sharp_corners/hairpins.toml --seed 100 101 --repetition 0 1 2 3 4 5 6 7 8 9 --workers 2 --out benchmarks/experiments/sharp_corners/results/hairpin_trace/oracle_cover_to_2.md
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import oracle_visited  # noqa: E402
import track_branch  # noqa: E402

#: [m] how far behind the rover along the track the cover reaches
COVER_TO_M = 2.0
#: ``--cover-leg``: the cover only on the leg that ends at the track's sharpest vertex
#: (``"incoming"``; ``"incoming-outer"``, ``"incoming-inner"``: only on the outer side of its
#: centreline, or only the turn's side) or only off it (``"others"``); "": wherever it lies
LEG = ""
#: ``--cover-start`` (part 75) [m]: the cover only of felt behind the lap's start (its centreline
#: in the loop's second half) and only while the rover's progress is below this; 0: off
START_M = 0.0


def turn_side_offset(track: Any, floor: np.ndarray) -> np.ndarray:
    """(N,) [m]: how far each floor point (N, 2) lies to the turn's side of the centreline of the
    leg that ends at ``track``'s sharpest vertex (negative: its outer side)."""
    vertices = np.asarray(track.vertices, dtype=np.float64)
    turns = np.asarray(track.vertex_turns_rad)
    k = int(np.argmax(np.abs(turns)))
    u = vertices[k] - vertices[k - 1]
    u = u / np.linalg.norm(u)
    rel = floor - vertices[k]
    left = u[0] * rel[:, 1] - u[1] * rel[:, 0]
    return np.sign(turns[k]) * left


def incoming_leg(track: Any) -> tuple[float, float]:
    """The arc lengths [m] along ``track`` (in driving order) where the leg ending at its
    sharpest vertex starts and ends."""
    k = int(np.argmax(np.abs(np.asarray(track.vertex_turns_rad))))
    at, legs = track_branch.vertex_arcs(track)
    end = float(at[k]) if k else float(track.length_m)
    return end - float(legs[k - 1]), end


class CoverNearMemory(oracle_visited.TrackVisitedMemory):
    """Part 12's oracle (``combine cover``, ``cover_from 0.3``) covering only felt whose
    centreline lies at most :data:`COVER_TO_M` behind the rover along the track."""

    def _kept(self, where: np.ndarray) -> np.ndarray | None:
        now = oracle_visited.NOW
        if now["track"] is None or not where.any():
            return super(oracle_visited.TrackVisitedMemory, self)._kept(where)
        own = super(oracle_visited.TrackVisitedMemory, self)._kept(where)
        if own is None:
            own = np.where(where, 1.0, 0.0)
        track = now["track"]
        floor = oracle_visited.to_floor(self._points[where], now["pose"])
        s = oracle_visited.centreline_at(track, floor)
        if track.closed:
            behind = (now["progress_m"] - s) % track.length_m
            reach = min(COVER_TO_M, 0.5 * track.length_m)
        else:
            behind, reach = now["progress_m"] - s, COVER_TO_M
        covered = (behind >= now["cover_from_m"]) & (behind <= reach)
        if LEG:
            start, end = incoming_leg(track)
            on_leg = (s >= start) & (s <= end)
            covered &= ~on_leg if LEG == "others" else on_leg
            if LEG in ("incoming-outer", "incoming-inner"):
                toward = turn_side_offset(track, floor)
                covered &= (toward <= 0.0) if LEG == "incoming-outer" else (toward > 0.0)
        if START_M:
            early = 0.0 <= now["progress_m"] < START_M
            covered &= (s > 0.5 * track.length_m) & early
        own = own.copy()
        own[where] = np.where(covered, 0.0, own[where])
        return own
