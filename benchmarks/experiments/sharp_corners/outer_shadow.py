"""Part 67 of ``README.md``: where ``outer_cover.py``'s map parts from the oracle it imitates.

The learner is taught and driven on part 66's oracle (part 12's cover of the hairpin's incoming
leg, outside its centreline only: ``cover_near.py --cover-leg incoming-outer``), and beside that
map an ``outer_cover.py`` map is fed the same frames and commands (a shadow: it drives nothing).
At every frame where the shadow has read a turn's side, the felt one map counts fresh and the
other does not is summed (felt-weighted, within the blank reach and ahead) by where the track puts
it: the hairpin's incoming leg outside its centreline, on its turn's side, or elsewhere (the
outgoing strip and the other legs). A measurement; it chooses nothing. ``--shadow`` feeds one
of ``edge_cover.py``'s maps beside instead (part 68).

    .venv/bin/python benchmarks/experiments/sharp_corners/outer_shadow.py --study benchmarks/experiments/sharp_corners/hairpins.toml --seed 100 --repetition 4 --out benchmarks/experiments/sharp_corners/results/outer_cover/shadow_100_4.md
"""

from __future__ import annotations

import collections
import sys
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import cover_near  # noqa: E402
import edge_cover  # noqa: E402
import hairpin_trace  # noqa: E402
import oracle_learner  # noqa: E402
import oracle_visited  # noqa: E402
import outer_cover  # noqa: E402

from lfd_track.policy.memory import BEHIND_M  # noqa: E402

#: felt-weighted sums: (which map counts it fresh, where the track puts it) -> felt
TALLY: collections.Counter[tuple[str, str]] = collections.Counter()
PLACES = ("incoming leg, outside", "incoming leg, turn's side", "elsewhere")
#: ``--shadow``: the prototype maps that can be fed beside the oracle
SHADOWS: dict[str, type[outer_cover.OuterCoverMemory]] = {
    "outer_cover": outer_cover.OuterCoverMemory,
    "edge_cover": edge_cover.EdgeCoverMemory,
    "strip_cover": edge_cover.StripCoverMemory,
    "edge_cover_track_side": edge_cover.TrackSideEdgeCoverMemory,
}
#: the shadow's class (``--shadow``)
SHADOW: list[type[outer_cover.OuterCoverMemory]] = [outer_cover.OuterCoverMemory]


class ShadowedMemory(cover_near.CoverNearMemory):
    """Part 66's oracle map with an ``outer_cover.py`` map fed beside it (module docstring)."""

    def reset(self) -> None:
        super().reset()
        self.shadow = SHADOW[0](self.config, self.geometry)

    def note(self, command: Any) -> None:
        super().note(command)
        self.shadow.note(command)

    def arrive(self, frame: np.ndarray) -> None:
        super().arrive(frame)
        self.shadow.arrive(frame)

    def place_before(self, command: Any) -> None:
        super().place_before(command)
        self.shadow.place_before(command)

    def see(self, values: np.ndarray, levels: tuple[float, float] | None = None) -> None:
        super().see(values, levels)
        self.shadow.see(values, levels)
        track = oracle_visited.NOW["track"]
        if not self.shadow._turn_side or track is None:
            return
        points = self._points
        near = np.hypot(points[:, 0], points[:, 1]) < (self.config.blank_reach_m or 1.0)
        ahead = points[:, 0] > -BEHIND_M
        shadow, oracle = self.shadow._fresh(near, ahead), self._fresh(near, ahead)
        floor = oracle_visited.to_floor(points, oracle_visited.NOW["pose"])
        arc = oracle_visited.centreline_at(track, floor)
        start, end = cover_near.incoming_leg(track)
        on_leg = (arc >= start) & (arc <= end)
        toward = cover_near.turn_side_offset(track, floor)
        where = (on_leg & (toward <= 0.0), on_leg & (toward > 0.0), ~on_leg)
        for place, mask in zip(PLACES, where, strict=True):
            TALLY["shadow", place] += float(np.clip(shadow - oracle, 0.0, None)[mask].sum())
            TALLY["oracle", place] += float(np.clip(oracle - shadow, 0.0, None)[mask].sum())


def main() -> None:
    parser = hairpin_trace.measure_parser(__doc__.splitlines()[0])
    parser.add_argument("--shadow", choices=tuple(SHADOWS), default="outer_cover")
    args = parser.parse_args()
    SHADOW[0] = SHADOWS[args.shadow]
    name = f"{args.shadow.removesuffix('_track_side')}.py"
    oracle_learner.use_oracle("cover", 0.3)
    cover_near.COVER_TO_M, cover_near.LEG = float("inf"), "incoming-outer"
    oracle_visited.maps_made_as(ShadowedMemory)
    laps = hairpin_trace.drive_repetitions(args.study, args.seed, args.repetition)
    lines = [
        f"# `{name}` beside the oracle it imitates (`{Path(args.study).name}`)",
        "",
        f"Seed {args.seed}, repetitions {args.repetition}, driven on part 66's oracle (the track's"
        " cover of the hairpin's incoming leg outside its centreline):"
        f" {sum(lap['success'] for lap in laps)} of {len(laps)} laps past 155° lapped. Felt one"
        " map counts fresh and the other not, summed over the frames where the shadow"
        f" (`{name}`, `COVER_FROM_M` {sys.modules[SHADOW[0].__module__].COVER_FROM_M:g} m)"
        " has read a side:",
        "",
        "| where the track puts it | fresh only on the shadow | fresh only on the oracle |",
        "|---|---|---|",
        *(
            f"| {place} | {TALLY['shadow', place]:.0f} | {TALLY['oracle', place]:.0f} |"
            for place in PLACES
        ),
    ]
    hairpin_trace.write_page(args.out, lines)


if __name__ == "__main__":
    main()
