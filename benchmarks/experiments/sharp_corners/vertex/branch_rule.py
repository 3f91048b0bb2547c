"""The map rule with the map's "branch side" (``turn_side.md``'s E5), on the trials of part 4.

A prototype, outside the library: ``FreshFeltMemory`` is wrapped from here (its inputs are
unchanged) to compute after every frame which side felt branched off the rover's strip over the
last metre of driving, and ``FreshFeltRule.act`` is wrapped to use it in one of two ways:

* ``blank`` — while the map is blank the rule pivots toward the branch side when there is one
  (else, as shipped, toward the side the fresh felt last lay on);
* ``veto`` — ``blank``, and a pivot *away* from a known branch side becomes a forward command
  (the rover drives on to where the map runs blank, then pivots toward the branch side).

The branch side, from the map's own arrays only (rover frame, x ahead, y left), at every frame:

1. the path's direction u: walking back from the axle along the places the rover has been, the
   oldest place p within 0.5 m of path; none if \\|p\\| < 0.15 m (the frame adds nothing); else
   u = -p / \\|p\\| and n = (-u_y, u_x);
2. for felt points (level >= 0.5), s = point . u and l = point . n; the centreline c is the
   felt-weighted mean of l over points with -0.5 <= s <= 0 and \\|l\\| < 0.5 (0 when their felt
   sums below 3);
3. the frame's value b = sum of felt levels times sign(l - c) over points with 0 < s <= 1.2 and
   0.3 < \\|l - c\\| < 1.0;
4. the branch side: the sign of the sum of b over the frames since the last 10 forward commands
   (1 m), when that sum's size exceeds 2.0; else none.

    .venv/bin/python benchmarks/experiments/sharp_corners/vertex/branch_rule.py --use blank --repetitions 9 --workers 1 --out benchmarks/experiments/sharp_corners/results/map_options/branch_blank

Writes what ``../../generalization/rules.py`` writes (``OUT/rules.md``, ``OUT/map-rule/``).
"""

from __future__ import annotations

import argparse
import importlib.util
import sys
from pathlib import Path
from typing import Any

import numpy as np

from lfd_track.core.commands import Command
from lfd_track.policy.memory import FreshFeltMemory
from lfd_track.teaching.handwritten import FreshFeltRule

HERE = Path(__file__).resolve().parent
RULES_PY = HERE.parents[1] / "generalization" / "rules.py"
STUDY = HERE.parent / "trials" / "sharp_corners.toml"

_spec = importlib.util.spec_from_file_location("rules", RULES_PY)
rules = importlib.util.module_from_spec(_spec)
sys.modules["rules"] = rules  # the pool's workers (forked) find its functions by this name
_spec.loader.exec_module(rules)

#: [m] path length that gives the path's direction; shorter than MIN_PATH_M: no frame value
PATH_M, MIN_PATH_M = 0.5, 0.15
#: [m] the centreline from felt between BEHIND_M behind the axle and the axle, within LANE_M
BEHIND_M, LANE_M, MIN_LANE_FELT = 0.5, 0.5, 3.0
#: [m] branch felt: ahead up to AHEAD_M, between NEAR_M and FAR_M off the centreline
AHEAD_M, NEAR_M, FAR_M = 1.2, 0.3, 1.0
#: forward commands the branch side looks back over (1 m), and the sum it needs
WINDOW_FORWARD, MIN_SUM = 10, 2.0

STATE: dict[str, Any] = {"use": "blank", "side": 0}

_reset, _note, _see, _act = (
    FreshFeltMemory.reset,
    FreshFeltMemory.note,
    FreshFeltMemory.see,
    FreshFeltRule.act,
)


def path_direction(path: np.ndarray) -> np.ndarray | None:
    """u, the unit direction the rover came along (None while the path is too short)."""
    places = np.vstack([path, np.zeros((1, 2))])
    steps = np.hypot(*np.diff(places, axis=0).T)
    back = np.concatenate([[0.0], np.cumsum(steps[::-1])])  # arc length from the axle back
    within = np.flatnonzero(back <= PATH_M)
    p = places[::-1][within[-1]]
    size = float(np.hypot(*p))
    return None if size < MIN_PATH_M else -p / size


def frame_value(points: np.ndarray, felt: np.ndarray, path: np.ndarray) -> float:
    """b: felt branching off to the left (+) or right (-) of the rover's strip ahead."""
    u = path_direction(path)
    if u is None:
        return 0.0
    n = np.array([-u[1], u[0]])
    on = felt >= 0.5
    s, lat, w = points[on] @ u, points[on] @ n, felt[on]
    lane = (s >= -BEHIND_M) & (s <= 0.0) & (np.abs(lat) < LANE_M)
    c = (
        float((w[lane] * lat[lane]).sum() / w[lane].sum())
        if w[lane].sum() >= MIN_LANE_FELT
        else 0.0
    )
    off = lat - c
    branch = (s > 0.0) & (s <= AHEAD_M) & (np.abs(off) > NEAR_M) & (np.abs(off) < FAR_M)
    return float((w[branch] * np.sign(off[branch])).sum())


def reset(self: FreshFeltMemory) -> None:
    _reset(self)
    self._branch: list[tuple[int, float]] = []  # (forward commands so far, b) per frame
    self._forward = 0
    STATE["side"] = 0


def note(self: FreshFeltMemory, command: Any) -> None:
    _note(self, command)
    if int(command) == Command.FORWARD:
        self._forward += 1


def see(self: FreshFeltMemory, values: np.ndarray, levels: Any = None) -> None:
    _see(self, values, levels)
    self._branch.append((self._forward, frame_value(self._points, self._felt, self._path)))
    self._branch = [(f, b) for f, b in self._branch if self._forward - f <= WINDOW_FORWARD]
    total = sum(b for _, b in self._branch)
    STATE["side"] = int(np.sign(total)) if abs(total) > MIN_SUM else 0


def act(self: FreshFeltRule, memory: np.ndarray) -> Command:
    command = _act(self, memory)
    side = STATE["side"]
    if side == 0:
        return command
    toward = Command.LEFT if side > 0 else Command.RIGHT
    if float(memory[1]) <= 0.0:  # blank: the branch side instead of the last one
        return toward
    if STATE["use"] == "veto" and command not in (Command.FORWARD, toward):
        return Command.FORWARD
    return command


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--use", choices=("blank", "veto"), required=True)
    parser.add_argument("--repetitions", type=int, default=9)
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    STATE["use"] = args.use
    FreshFeltMemory.reset = reset
    FreshFeltMemory.note = note
    FreshFeltMemory.see = see
    FreshFeltRule.act = act
    sys.argv = [
        str(RULES_PY),
        "--study", str(STUDY),
        "--condition", "paper",
        "--rule", "map-rule",
        "--out", str(args.out),
        "--repetitions", str(args.repetitions),
        "--workers", str(args.workers),
    ]  # fmt: skip
    rules.main()


if __name__ == "__main__":
    main()
