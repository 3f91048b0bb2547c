"""The map rule with the map's "branch side" (``turn_side.md``'s E5), on the trials of part 4.

First a prototype that computed the side itself; the side is now the map's optional fourth input
(``[memory] branch_side``, ``lfd_track/policy/branch_side.py``, the estimator below with the same
constants; part 7 of ``../README.md`` checks it lap for lap against this script's first runs).
The map rule on a map with it already pivots toward the side while the map is blank; this script
drives ``../../generalization/rules.py``'s map rule on that map, in one of two uses:

* ``blank`` — while the map is blank the rule pivots toward the branch side when there is one
  (else, as shipped, toward the side the fresh felt last lay on): the library's rule as it is;
* ``veto`` — ``blank``, and a pivot *away* from a known branch side becomes a forward command
  (the rover drives on to where the map runs blank, then pivots toward the branch side):
  ``FreshFeltRule.act`` wrapped from here.

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
from lfd_track.policy.branch_side import side_command
from lfd_track.teaching.handwritten import FreshFeltRule

HERE = Path(__file__).resolve().parent
RULES_PY = HERE.parents[1] / "generalization" / "rules.py"
STUDY = HERE.parent / "trials" / "sharp_corners.toml"

_spec = importlib.util.spec_from_file_location("rules", RULES_PY)
rules = importlib.util.module_from_spec(_spec)
sys.modules["rules"] = rules  # the pool's workers (forked) find its functions by this name
_spec.loader.exec_module(rules)

_act = FreshFeltRule.act


def act_with_veto(self: FreshFeltRule, memory: np.ndarray) -> Any:
    """The library's rule on the map with the branch side, and no pivot away from a known side
    while fresh felt is left."""
    command = _act(self, memory)
    toward = side_command(float(memory[3]))
    if toward is not None and float(memory[1]) > 0.0 and command not in (Command.FORWARD, toward):
        return Command.FORWARD
    return command


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--use", choices=("blank", "veto"), required=True)
    parser.add_argument("--repetitions", type=int, default=9)
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    if args.use == "veto":
        FreshFeltRule.act = act_with_veto  # type: ignore[method-assign]
    sys.argv = [
        str(RULES_PY),
        "--study", str(STUDY),
        "--condition", "paper",
        "--rule", "map-rule",
        "--map", "branch_side=true",
        "--out", str(args.out),
        "--repetitions", str(args.repetitions),
        "--workers", str(args.workers),
    ]  # fmt: skip
    rules.main()


if __name__ == "__main__":
    main()
