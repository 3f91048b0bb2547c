"""Where the felt lies that part 12's oracle makes visited (part 13 of ``README.md``).

Drives the map rule on the map as it is (``../generalization/rules.py``, its arguments passed
on) and records the moments at which part 12's oracle (``oracle_visited.py --combine cover
--cover-from 0.3``) would change the map most: fresh felt of the map's whose centreline lies at
least 0.3 m of track behind the rover, weighing more than ``MIN_MASS``. The first ``PER_JOB`` such
moments of each job are drawn on the floor (``--figures DIR``: one PNG each; strips green, felt
the map holds grey, its fresh felt red where the oracle makes it visited and yellow where not,
the rover's path blue, the rover white), and ``dead_ends.py``'s test is scored on them: the share
of each colour's fresh felt it leaves out.

    .venv/bin/python benchmarks/experiments/sharp_corners/tips.py --figures benchmarks/experiments/sharp_corners/results/oracle_visited/tips --study benchmarks/experiments/human_goal/round27/balance.toml --condition rooms.round20+visual+balance --rule map-rule --map branch_side=true --map branch_window=commands --map motion=visual --map colour_balance=safe_box --repetitions 2 --out /tmp/tips --workers 2
"""

from __future__ import annotations

import math
import os
import pickle
import sys
from pathlib import Path
from typing import Any

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import dead_ends  # noqa: E402
import oracle_visited  # noqa: E402

from lfd_track.policy.memory import FreshFeltMemory  # noqa: E402

#: A moment is recorded when the fresh felt the oracle makes visited weighs more than this.
MIN_MASS = 1.5
#: Moments recorded per job (per worker process, at most).
PER_JOB = 16
BEHIND_M = 0.3
FIGURES: dict[str, Path | None] = {"dir": None}
MOMENTS: list[dict[str, Any]] = []


def moment(
    memory: FreshFeltMemory, chosen: np.ndarray, weights: np.ndarray, behind: np.ndarray
) -> dict[str, Any]:
    """What :func:`draw` draws of ``memory``'s map now: its points, felt and path, the episode's
    strips and pose (``oracle_visited.NOW``), and the fresh felt points ``chosen`` with their
    ``weights`` and whether the oracle counts each ``behind``."""
    now = oracle_visited.NOW
    return {
        "pose": now["pose"],
        "strips": [np.asarray(p) for p in now["track"].strip_polygons()],
        "points": memory._points.copy(),
        "felt": memory._felt.copy(),
        "path": memory._path.copy(),
        "chosen": chosen,
        "weights": weights,
        "behind": behind,
    }


class TipMemory(FreshFeltMemory):
    """The map as it is, recording the moments part 12's oracle changes most."""

    def _fresh(self, near: np.ndarray, ahead: np.ndarray) -> np.ndarray:
        weights = super()._fresh(near, ahead)
        now = oracle_visited.NOW
        chosen = np.flatnonzero(weights > 0.0)
        if now["track"] is None or not len(chosen) or len(MOMENTS) >= PER_JOB:
            return weights
        floor = oracle_visited.to_floor(self._points[chosen], now["pose"])
        track_fresh = oracle_visited.track_ahead(now["track"], floor, now["progress_m"], BEHIND_M)
        if float(weights[chosen][~track_fresh].sum()) > MIN_MASS:
            MOMENTS.append(moment(self, chosen, weights[chosen], ~track_fresh))
            folder = FIGURES["dir"]
            assert folder is not None
            with open(folder / f"moments_{os.getpid()}.pkl", "wb") as out:
                pickle.dump(MOMENTS, out)
        return weights


def draw(moment: dict[str, Any], path: Path, scale: float = 200.0, size: int = 400) -> None:
    x, y, heading = moment["pose"]

    def pixel(p: np.ndarray) -> tuple[int, int]:
        return int(size / 2 + (p[0] - x) * scale), int(size / 2 - (p[1] - y) * scale)

    image = np.full((size, size, 3), 60, np.uint8)
    for strip in moment["strips"]:
        cv2.fillPoly(image, [np.array([pixel(p) for p in strip], np.int32)], (90, 140, 90))
    floor = oracle_visited.to_floor(moment["points"], moment["pose"])
    for p in floor[moment["felt"] >= 0.5]:
        cv2.circle(image, pixel(p), 2, (200, 200, 200), -1)
    for p, behind in zip(floor[moment["chosen"]], moment["behind"], strict=True):
        cv2.circle(image, pixel(p), 4, (0, 0, 255) if behind else (0, 255, 255), -1)
    for p in oracle_visited.to_floor(moment["path"], moment["pose"]):
        cv2.circle(image, pixel(p), 3, (255, 100, 0), -1)
    tip = (x + 0.3 * math.cos(heading), y + 0.3 * math.sin(heading))
    cv2.arrowedLine(image, pixel(np.array([x, y])), pixel(np.array(tip)), (255, 255, 255), 2)
    cv2.imwrite(str(path), image)


def main() -> None:
    at = sys.argv.index("--figures")
    folder = FIGURES["dir"] = Path(sys.argv[at + 1])
    del sys.argv[at : at + 2]
    folder.mkdir(parents=True, exist_ok=True)
    for old in folder.glob("moments_*.pkl"):
        old.unlink()
    oracle_visited.main(TipMemory)
    moments = []
    for saved in sorted(folder.glob("moments_*.pkl")):
        with open(saved, "rb") as f:
            moments += pickle.load(f)
        saved.unlink()
    out = {"behind": [0.0, 0.0], "ahead": [0.0, 0.0]}
    for k, drawn in enumerate(moments):
        draw(drawn, folder / f"moment{k:02d}.png")
        gone = dead_ends.leads_nowhere(drawn["points"], drawn["felt"], drawn["chosen"])
        for name, part in (("behind", drawn["behind"]), ("ahead", ~drawn["behind"])):
            out[name][0] += float(drawn["weights"][part & gone].sum())
            out[name][1] += float(drawn["weights"][part].sum())
    print(f"{len(moments)} moments drawn in {folder}")
    for name, (left_out, total) in out.items():
        share = left_out / total if total else 0.0
        print(f"dead_ends.py leaves out {share:.0%} of the fresh felt the oracle counts {name}")


if __name__ == "__main__":
    main()
