"""Round 36's candidate map, a prototype: how far the felt runs on straight ahead, one more input.

At a sharp corner's end the map's fresh felt is the corner's tip, straight ahead, and the learner
drives on into it where the track's own visited felt would have turned it toward the outgoing
strip (``../../sharp_corners/`` parts 12-15 and 27). The tip is short: carpet lies a few tenths of a
metre ahead in the rover's own lane, where on a strip that runs on the felt reaches as far as the
map sees. Part 15's hand-written tests blanked the map where the rover's strip ends within 0.3-0.6
m ahead, and changed 7 to 70 times as many of the rule's commands as they fixed; a learner taught
by the human model, who turns at the junction, may weigh the same fact where the human does. This
map gives it one more input after the map's own: the distance straight ahead to the nearest
carpet in the rover's lane (map points within :data:`LANE_M` of the heading line, from
:data:`FROM_M` to :data:`RUN_M` ahead, whose felt level is at most :data:`CARPET_AT`), over
:data:`RUN_M` (1: no carpet there). A mirror image leaves it as it is (the lane is symmetric).

Every ``fresh_felt`` map of the study job is this one, in the human model's demonstration, the
fits and the driving; one seed's jobs per process (``../../sharp_corners/oracle_learner.py``'s
``run_with_more_inputs``). A prototype: the product's map has no such setting.

    .venv/bin/python benchmarks/experiments/human_goal/round36/ahead.py --seed 100 --study benchmarks/experiments/human_goal/round36/ahead.toml --out benchmarks/experiments/human_goal/round36/results/ahead
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "sharp_corners"))

import oracle_learner  # noqa: E402

from lfd_track.policy.memory import FreshFeltMemory  # noqa: E402

#: [m] the rover's lane: map points this close to the heading line
LANE_M = 0.1
#: [m] the lane is read from this far ahead of the axle ...
FROM_M = 0.1
#: [m] ... to this far (the input's 1)
RUN_M = 1.0
#: a map point whose felt level is at most this is carpet
CARPET_AT = 0.25


class AheadMemory(FreshFeltMemory):
    """The ``fresh_felt`` map with how far the felt runs on ahead as one more input."""

    def __init__(self, config: Any, geometry: Any = None) -> None:
        super().__init__(config, geometry)
        self._run = 1.0

    def reset(self) -> None:
        super().reset()
        self._run = 1.0

    def see(self, values: np.ndarray, levels: tuple[float, float] | None = None) -> None:
        super().see(values, levels)
        x, y = self._points[:, 0], self._points[:, 1]
        lane = (np.abs(y) <= LANE_M) & (x >= FROM_M) & (x <= RUN_M) & (self._felt <= CARPET_AT)
        self._run = float(x[lane].min()) / RUN_M if lane.any() else 1.0

    def inputs(self) -> np.ndarray:
        return np.append(super().inputs(), self._run)


def main() -> None:
    # the run ahead stays as it is in a mirror image
    oracle_learner.run_with_more_inputs(AheadMemory, 1, lambda run: run, __doc__.splitlines()[0])


if __name__ == "__main__":
    main()
