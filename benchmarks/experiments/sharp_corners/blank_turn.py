"""Part 60 of ``README.md``: how far the rover has turned on a blank map, as one more input (a
prototype map).

Part 59's traces (``hairpin_trace.py``) find the rover spinning at hairpins past 155°: the map
goes blank at the vertex and it pivots round and round, passing the heading of the outgoing strip
with nothing fresh ahead, since that strip lies within the path's radius of the incoming one, and
nothing tells the learner that it faces the way on. (Written on the lost laps' spins; counted over
every lap, part 59 later found the spin as common in laps lapped.) The human model turns there by
the track; what its turn looks like to the map is a blank map and a heading turned. This map
gives the learner that: one input after the map's own, the heading the rover has turned since
the map last held fresh felt (left positive), ``0.5 + turn / 360°`` clipped to [0, 1], and 0.5
while the map holds fresh felt. The turn is summed from the motions the map moves by (the
camera's measured motion, or the nominal pivot where that is not reliable). In a mirror image
it is ``1 - x``.

Every ``fresh_felt`` map of the job is this one, in the human model's demonstration (its cases
carry the input), the fits and the driving (``oracle_learner.use_more_inputs``); the cases other
rooms' demonstrations add (``extra_cases``) must be collected on this map too (``collect``, as
``../human_goal/round41/prior.py collect`` does). A prototype: the product's map has no such
setting.

    .venv/bin/python benchmarks/experiments/sharp_corners/blank_turn.py collect --cases benchmarks/experiments/sharp_corners/results/blank_turn/prior_cases --study benchmarks/experiments/human_goal/round42/prior_rooms.toml --out /tmp/blank_turn_rooms
    .venv/bin/python benchmarks/experiments/sharp_corners/blank_turn.py run --study benchmarks/experiments/sharp_corners/hairpins_blank_turn.toml --out benchmarks/experiments/sharp_corners/results/hairpins_blank_turn
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import oracle_learner  # noqa: E402

PRIOR_PY = Path(__file__).resolve().parents[1] / "human_goal" / "round41" / "prior.py"


class TurnOnBlank(oracle_learner.PrototypeMemory):
    """The ``fresh_felt`` map counting the heading turned since it last held fresh felt
    (``_blank_turn`` [deg], left positive), summed from the motions it moves by; its inputs are
    the map's own (:class:`BlankTurnMemory` adds the count as one, ``turned_ahead.py`` lays a
    corridor by it)."""

    def reset(self) -> None:
        super().reset()
        self._blank_turn = 0.0  # [deg] turned since the map last held fresh felt

    def _move(self, command: int, measured: Any = None) -> None:
        super()._move(command, measured)
        self._blank_turn += self._command_motion(command, measured)[1]

    def see(self, values: np.ndarray, levels: tuple[float, float] | None = None) -> None:
        super().see(values, levels)
        if self.bearing_deg is not None:  # fresh felt: the count starts again
            self._blank_turn = 0.0


class BlankTurnMemory(TurnOnBlank):
    """The ``fresh_felt`` map with the turn since it last held fresh felt as one more input."""

    def inputs(self) -> np.ndarray:
        if self.bearing_deg is not None:
            turned = 0.5
        else:
            turned = min(1.0, max(0.0, 0.5 + self._blank_turn / 360.0))
        return np.append(super().inputs(), turned)


def use_blank_turn() -> None:
    """From now on every ``fresh_felt`` map of this process is a :class:`BlankTurnMemory`."""
    oracle_learner.use_more_inputs(BlankTurnMemory, 1, lambda turned: 1.0 - turned)


def load_prior() -> Any:
    """``../human_goal/round41/prior.py`` as a module (its ``collect_into``)."""
    spec = importlib.util.spec_from_file_location("prior", PRIOR_PY)
    assert spec is not None and spec.loader is not None
    prior = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(prior)
    return prior


def main() -> None:
    parser = oracle_learner.study_parser(__doc__.splitlines()[0])
    parser.add_argument("step", choices=("collect", "run"))
    parser.add_argument("--cases", help="collect: the folder the cases are saved into")
    args = parser.parse_args()
    use_blank_turn()
    if args.step == "collect":
        if not args.cases:
            raise SystemExit("collect needs --cases")
        load_prior().collect_into(Path(args.cases))
    # the study's tables once all of its jobs are there (run again to write them: it skips the
    # jobs already there)
    oracle_learner.run_in_process(args.study, args.out, args.seed, tables=args.step == "run")


if __name__ == "__main__":
    main()
