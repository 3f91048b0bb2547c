"""The map rule with fresh felt that leads nowhere left out: does a dead-end test lift the sharp
corners? (part 13 of ``README.md``)

Part 12's oracle covered only felt at least 0.3 m of track behind the rover and kept the
every-room bar. Drawn at the moments it changes the map (the map's fresh felt it makes visited),
that felt is a sharp corner's tip: the incoming strip past where the outgoing one leaves it, which
the rover never drove into because it turned onto the outgoing strip before it. A rover at the
junction sees that tip fresh and ahead, and drives into it and off its end.

A robot can see that the tip ends: beyond it, the map holds carpet. Here a fresh felt point p of
the ``fresh_felt`` map weighs nothing when the map's points beyond it (along the line from the
axle through p, from ``NEAR_M`` to ``FAR_M`` further, within ``LANE_M`` of that line) number at
least ``MIN_SEEN`` and their mean felt level is below ``MAX_FELT``: carpet seen where a strip
would go on. Everything else (the camera, the road library, visited felt, the strip links, the
reach, the branch side, the rule) is the map rule's own. Drives ``../generalization/rules.py``
unchanged (its arguments are passed on).

``--whole-tip`` (part 14) also leaves out, where the rover's own strip ends within 0.6 m ahead
(carpet seen along its heading), the fresh felt ahead of the axle short of that end, within
0.35 m of the heading: the tip as a whole, not point by point.

    .venv/bin/python benchmarks/experiments/sharp_corners/dead_ends.py --study benchmarks/experiments/human_goal/round27/balance.toml --condition rooms.round20+visual+balance --rule map-rule --map branch_side=true --map branch_window=commands --map motion=visual --map colour_balance=safe_box --out benchmarks/experiments/sharp_corners/results/oracle_visited/rooms_dead_ends --workers 2
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import oracle_visited  # noqa: E402

from lfd_track.policy.memory import FreshFeltMemory  # noqa: E402

#: [m] The stretch beyond a fresh felt point whose map points are looked at: from ``NEAR_M`` to
#: ``FAR_M`` further from the axle along the line through the point, within ``LANE_M`` of it.
NEAR_M, FAR_M, LANE_M = 0.2, 0.5, 0.45
#: A fresh felt point leads nowhere when at least ``MIN_SEEN`` map points lie in that stretch
#: and their mean felt level is below ``MAX_FELT``.
MIN_SEEN, MAX_FELT = 3, 0.15


def leads_nowhere(points: np.ndarray, felt: np.ndarray, chosen: np.ndarray) -> np.ndarray:
    """(K,) bool for the map points ``chosen`` (K,) int of ``points`` (N, 2) [m, rover frame]
    with felt levels ``felt`` (N,): carpet seen beyond each (element by element, no BLAS)."""
    seen, level = beyond(points, felt, chosen)
    return (seen >= MIN_SEEN) & (level < MAX_FELT)


def beyond(
    points: np.ndarray, felt: np.ndarray, chosen: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(K,) int and (K,) float64: how many of the map's points lie beyond each chosen point
    (from ``NEAR_M`` to ``FAR_M`` further along the line from the axle, within ``LANE_M`` of it)
    and their mean felt level (0 where there are none)."""
    reach = np.hypot(points[chosen, 0], points[chosen, 1])
    ux, uy = points[chosen, 0] / reach, points[chosen, 1] / reach
    along = points[None, :, 0] * ux[:, None] + points[None, :, 1] * uy[:, None]
    across = points[None, :, 1] * ux[:, None] - points[None, :, 0] * uy[:, None]
    lane = (
        (along >= reach[:, None] + NEAR_M)
        & (along <= reach[:, None] + FAR_M)
        & (np.abs(across) <= LANE_M)
    )
    seen = lane.sum(axis=1)
    return seen, (lane * felt[None, :]).sum(axis=1) / np.maximum(seen, 1)


#: ``--whole-tip`` (part 14): the rover's own strip ends ahead where, within ``END_LANE_M`` of
#: its heading, the map's points over ``END_SPAN_M`` from some distance between ``END_FROM_M``
#: and ``END_TO_M`` ahead (in steps of ``END_STEP_M``) are at least ``MIN_SEEN`` with mean felt
#: level below ``MAX_FELT``; then the fresh felt ahead of the axle short of that distance (and
#: ``END_STEP_M`` past it), within ``TIP_LANE_M`` of the heading, leads nowhere too.
END_LANE_M, END_SPAN_M, END_FROM_M, END_TO_M, END_STEP_M = 0.1, 0.3, 0.1, 0.6, 0.05
TIP_LANE_M = 0.35
WHOLE_TIP = {"on": False}


def strip_end_m(points: np.ndarray, felt: np.ndarray, end_to_m: float = END_TO_M) -> float | None:
    """[m] How far ahead the rover's own strip ends (carpet seen along its heading, looked for
    up to ``end_to_m``), or None."""
    lane = np.abs(points[:, 1]) <= END_LANE_M
    steps = int(round((end_to_m - END_FROM_M) / END_STEP_M))
    for k in range(steps + 1):
        start = END_FROM_M + k * END_STEP_M
        beyond = lane & (points[:, 0] >= start) & (points[:, 0] <= start + END_SPAN_M)
        seen = int(beyond.sum())
        if seen >= MIN_SEEN and float((felt * beyond).sum()) / seen < MAX_FELT:
            return start
    return None


def whole_tip(points: np.ndarray, felt: np.ndarray, chosen: np.ndarray) -> np.ndarray:
    """(K,) bool for the map points ``chosen`` (K,) int: part 13's test, or (part 14) ahead of
    the axle short of where the rover's own strip ends, within ``TIP_LANE_M`` of its heading."""
    gone = leads_nowhere(points, felt, chosen)
    end = strip_end_m(points, felt)
    if end is not None:
        x, y = points[chosen, 0], points[chosen, 1]
        gone |= (x >= 0.0) & (x < end + END_STEP_M) & (np.abs(y) <= TIP_LANE_M)
    return gone


class DeadEndMemory(FreshFeltMemory):
    """The ``fresh_felt`` map whose fresh felt leaves out felt that leads nowhere."""

    def _fresh(self, near: np.ndarray, ahead: np.ndarray) -> np.ndarray:
        weights = super()._fresh(near, ahead)
        chosen = np.flatnonzero(weights > 0.0)
        if not len(chosen):
            return weights
        if WHOLE_TIP["on"]:
            gone = whole_tip(self._points, self._felt, chosen)
        else:
            gone = leads_nowhere(self._points, self._felt, chosen)
        weights[chosen[gone]] = 0.0
        return weights


def main() -> None:
    if "--whole-tip" in sys.argv:
        sys.argv.remove("--whole-tip")
        WHOLE_TIP["on"] = True
    oracle_visited.map_rule_with(DeadEndMemory)


if __name__ == "__main__":
    main()
