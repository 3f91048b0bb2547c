"""Part 64 of ``README.md``: what the strip's centres would cover in a spin, against the track.

``spin_side.py --spin-band`` covers, in a spin, the felt within 0.25 m of the strip's centres, as
part 12's oracle covers the felt the track puts 0.3 m or more behind the rover. This script
teaches and drives the repetitions it is given on that map (``hairpin_trace.py``'s laps past 155°)
and, at every frame of a spin, sorts the felt the map as it is counts fresh (felt-weighted, within
the map's reach and ahead) by whether the track puts it behind (the oracle would cover it) and by
its distance to the nearest centre: a band that tells the incoming strip from the outgoing one
would hold the felt behind and little of the felt ahead. A measurement; it chooses nothing.

    .venv/bin/python benchmarks/experiments/sharp_corners/band_cover.py --study benchmarks/experiments/sharp_corners/hairpins.toml --seed 100 --repetition 0 1 --out benchmarks/experiments/sharp_corners/results/spin_side/band_cover.md
"""

from __future__ import annotations

import collections
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import hairpin_trace  # noqa: E402
import oracle_visited  # noqa: E402
import spin_side  # noqa: E402
import track_branch  # noqa: E402

#: [m] the distance bins to the nearest centre
BIN_M = 0.05
#: felt-weighted sums: (the track puts it behind, distance bin) -> felt
TALLY: collections.Counter[tuple[bool, int]] = collections.Counter()
#: [m] felt behind further than this from every centre is also tallied by how far behind
FAR_M = 0.45
#: [m] the bins of how far behind along the track
BACK_BIN_M = 0.25
#: felt-weighted sums of that felt: bin of its track distance behind the rover -> felt
BACK: collections.Counter[int] = collections.Counter()


class BandCoverMemory(spin_side.SpinBandMemory):
    """``spin_side.py``'s band map that tallies, in spins, what the band covers (:data:`TALLY`)."""

    def _kept(self, where: np.ndarray) -> np.ndarray | None:
        kept = super()._kept(where)
        now = oracle_visited.NOW
        if not self._spin or not len(self._centres) or now["track"] is None or not where.any():
            return kept
        own = super(spin_side.SpinSideMemory, self)._kept(where)
        if own is None:
            return kept
        chosen = self._points[where]
        floor = oracle_visited.to_floor(chosen, now["pose"])
        behind = ~oracle_visited.track_ahead(now["track"], floor, now["progress_m"], 0.3)
        gap_x = chosen[:, 0, None] - self._centres[None, :, 0]
        gap_y = chosen[:, 1, None] - self._centres[None, :, 1]
        nearest = np.sqrt((gap_x * gap_x + gap_y * gap_y).min(axis=1))
        weight = self._felt[where] * (own[where] > 0.5)
        for is_behind, k, w in zip(behind, (nearest / BIN_M).astype(int), weight, strict=True):
            TALLY[bool(is_behind), int(k)] += float(w)
        # how far behind along the track the felt behind lies, far from every centre
        far = behind & (nearest > FAR_M)
        if far.any():
            track = now["track"]
            gap = now["progress_m"] - oracle_visited.centreline_at(track, floor[far])
            gap %= track.length_m
            for k, w in zip((gap / BACK_BIN_M).astype(int), weight[far], strict=True):
                BACK[int(k)] += float(w)
        return kept


def main() -> None:
    args = hairpin_trace.measure_parser(__doc__.splitlines()[0]).parse_args()
    track_branch.use_track_branch()  # the episode's track and progress for the tally
    oracle_visited.maps_made_as(BandCoverMemory)
    laps = hairpin_trace.drive_repetitions(args.study, args.seed, args.repetition)
    behind = sum(v for (b, _), v in TALLY.items() if b)
    ahead = sum(v for (b, _), v in TALLY.items() if not b)
    top = max((k for _, k in TALLY), default=0)
    lines = [
        f"# The strip's centres against the track's cover, in spins (`{Path(args.study).name}`)",
        "",
        f"Seed {args.seed}, repetitions {args.repetition}, on `spin_side.py`'s `--spin-band`"
        f" map: {sum(lap['success'] for lap in laps)} of {len(laps)} laps past 155° lapped."
        " Felt the map as it is counts fresh in spins (felt-weighted, summed over frames), by"
        " its distance to the strip's nearest centre and by whether the track puts it 0.3 m or"
        f" more behind the rover (part 12's cover): {behind:.0f} behind, {ahead:.0f} ahead.",
        "",
        "| distance to the nearest centre [m] | felt behind | felt ahead |",
        "|---|---|---|",
        *(
            f"| {k * BIN_M:.2f}–{(k + 1) * BIN_M:.2f} | {TALLY[True, k]:.0f} |"
            f" {TALLY[False, k]:.0f} |"
            for k in range(top + 1)
        ),
        "",
        f"The felt behind lying more than {FAR_M:g} m from every centre, by how far behind the"
        " rover's progress the track puts it:",
        "",
        "| behind along the track [m] | felt |",
        "|---|---|",
        *(
            f"| {k * BACK_BIN_M:.2f}–{(k + 1) * BACK_BIN_M:.2f} | {BACK[k]:.0f} |"
            for k in range(max(BACK, default=-1) + 1)
        ),
    ]
    hairpin_trace.write_page(args.out, lines)


if __name__ == "__main__":
    main()
