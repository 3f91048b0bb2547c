"""Part 68 of ``README.md``: the felt part 66's cover takes off the goal's map as the rover comes
up to a hairpin's vertex.

The learner is taught on the goal's own map and driven on part 66's oracle (``cover_near.py``'s
cover of the hairpin's incoming leg outside its centreline, on all the time), as
``hairpin_trace.py --oracle --cover-leg incoming-outer --taught-on-own`` drives it. At each frame
of one lap while the rover lies within ``--before`` metres before the vertex along the incoming
strip, the felt the goal's own map counts fresh and the oracle covers is summed, and its place
printed: along the incoming strip from the vertex (negative before it), to the turn's side of
the incoming centreline (negative: its outer side), ahead of the rover in its own frame, and how
far behind the rover's progress the track puts it; beside, the rover's progress against the
vertex's. A measurement on one validation lap; it chooses nothing.

    .venv/bin/python benchmarks/experiments/sharp_corners/tip_ahead.py --study benchmarks/experiments/sharp_corners/hairpins.toml --seed 100 --repetition 0 --track random:validation:401 --direction cw --out benchmarks/experiments/sharp_corners/results/edge_cover/tip_ahead_100_0_401cw.md
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import cover_near  # noqa: E402
import hairpin_trace  # noqa: E402
import oracle_learner  # noqa: E402
import oracle_visited  # noqa: E402

from lfd_track.policy.memory import BEHIND_M  # noqa: E402

#: the lap looked at, and how far before the vertex (set from the command line)
LAP: dict[str, Any] = {"track": "", "direction": "", "before_m": 1.0}
LINES: list[str] = []


class TipAheadMemory(cover_near.CoverNearMemory):
    """Part 66's oracle, summing at each frame what it covers that the goal's map keeps fresh."""

    def reset(self) -> None:
        super().reset()
        self.frames = 0

    def see(self, values: np.ndarray, levels: tuple[float, float] | None = None) -> None:
        super().see(values, levels)
        self.frames += 1
        track = oracle_visited.NOW["track"]
        if track is None or track.name != LAP["track"] or LAP["direction"] != DIRECTION[0]:
            return
        vertex, a_in, turn, s_vertex = hairpin_trace.hairpin(track)
        pose = oracle_visited.NOW["pose"]
        along = float((np.array(pose[:2]) - vertex) @ a_in)
        if not -LAP["before_m"] <= along <= 0.0:
            return
        points = self._points
        near = np.hypot(points[:, 0], points[:, 1]) < self.config.reach_m
        inside = near & (points[:, 0] > -BEHIND_M) & (self._felt > 0.0)
        own = super(oracle_visited.TrackVisitedMemory, self)._kept(inside)
        oracle = self._kept(inside)
        progress = float(oracle_visited.NOW["progress_m"])
        row = f"| {self.frames} | {along:+.2f} | {progress - s_vertex:+.2f} |"
        if own is None or oracle is None:
            LINES.append(row + " 0.0 | – | – | – | – |")
            return
        taken = (own - oracle) * self._felt * inside
        idx = np.flatnonzero(taken > 0.0)
        if not len(idx):
            LINES.append(row + " 0.0 | – | – | – | – |")
            return
        floor = oracle_visited.to_floor(points[idx], pose)
        rel = floor - vertex
        sign = 1.0 if turn > 0 else -1.0
        side = sign * (a_in[0] * rel[:, 1] - a_in[1] * rel[:, 0])
        arc = oracle_visited.centreline_at(track, floor)
        behind = (progress - arc) % track.length_m

        def span(values: np.ndarray) -> str:
            return f"{values.min():+.2f} to {values.max():+.2f}"

        LINES.append(
            row + f" {taken.sum():.1f} | {span(rel @ a_in)} | {span(side)} |"
            f" {span(points[idx, 0])} | {span(behind)} |"
        )


#: the direction of the lap looked at (``cw`` or ``ccw``), read where the env is made
DIRECTION = [""]
_make = hairpin_trace.LfDTrackEnv


def made(*args: Any, **kw: Any) -> Any:
    """``hairpin_trace.py``'s env, noting each lap's direction (its ``reverse``)."""
    DIRECTION[0] = "cw" if kw.get("reverse") else "ccw"
    return _make(*args, **kw)


def main() -> None:
    parser = hairpin_trace.measure_parser(__doc__.splitlines()[0])
    parser.add_argument("--track", required=True, help="the loop, e.g. random:validation:401")
    parser.add_argument("--direction", choices=("cw", "ccw"), required=True)
    parser.add_argument("--before", type=float, default=1.0, help="[m] before the vertex")
    args = parser.parse_args()
    LAP.update(track=args.track, direction=args.direction, before_m=args.before)
    oracle_learner.use_oracle("cover", 0.3)
    cover_near.COVER_TO_M, cover_near.LEG = float("inf"), "incoming-outer"
    oracle_visited.maps_made_as(TipAheadMemory)
    hairpin_trace.TAUGHT_ON_OWN = True
    hairpin_trace.LfDTrackEnv = made  # type: ignore[misc, assignment]
    laps = hairpin_trace.drive_repetitions(args.study, args.seed, args.repetition)
    lap = [x for x in laps if x["track"] == args.track and x["direction"] == args.direction]
    lines = [
        f"# Part 66's cover against the goal's map before a hairpin's vertex (`{args.track}`"
        f" {args.direction})",
        "",
        f"Seed {args.seed}, repetition {args.repetition}: the learner taught on the goal's map,"
        " driven on part 66's oracle (the hairpin's incoming leg outside its centreline covered,"
        " on all the time); the lap was "
        + ("lapped" if lap and lap[0]["success"] else "lost")
        + f". Frames with the rover up to {args.before:g} m before the vertex: the felt the goal's"
        " map counts fresh and the oracle covers (felt-weighted, within the map's reach and"
        " ahead), and where it lies [m].",
        "",
        "| frame | rover along | rover's progress past the vertex's | felt taken | along |"
        " turn's side | ahead of the rover | behind the progress |",
        "|---|---|---|---|---|---|---|---|",
        *LINES,
    ]
    hairpin_trace.write_page(args.out, lines)


if __name__ == "__main__":
    main()
