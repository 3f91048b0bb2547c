"""Round 35's candidate map, a prototype: the fresh felt on either side as two more inputs.

The ``fresh_felt`` map gives the learner one bearing for all of its fresh felt, the mean of
where it lies. At a sharp corner's end the corner's tip lies ahead and the outgoing strip to the
side (``../../sharp_corners/`` parts 12-15): their mean points between, ahead more often than
not, and the map rule drives on into the tip where the track's own visited felt would have
turned it (part 15: the oracle changes the rule's command there, mostly to a pivot toward the
branch side). A learner taught by the human model, who turns there, can use what the mean
hides. This map gives it two more inputs after the map's own: how much fresh felt lies more than
:data:`SIDE_DEG` to the left of the rover's heading and how much more than that to the right
(each the felt's weight as fresh, summed, over the map's full amount, clipped to 1; both 0 when
the map has no fresh felt). The turn of the map rule is 20 degrees, so "to the side" is what the
rule would pivot toward. In a mirror image the two swap.

Every ``fresh_felt`` map of the study job is this one, in the human model's demonstration (its
cases carry the two inputs), the fits (the network reads them) and the driving; the job runs in
this process, one seed per process (``../../sharp_corners/oracle_learner.py``'s
``run_with_more_inputs``). The jobs' results record the study's configuration; the study's own name
and description say what the map adds. A prototype: the product's map has no such setting.

    .venv/bin/python benchmarks/experiments/human_goal/round35/sides.py --seed 100 --study benchmarks/experiments/human_goal/round35/sides.toml --out benchmarks/experiments/human_goal/round35/results/sides
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "sharp_corners"))

import oracle_learner  # noqa: E402

from lfd_track.policy.memory import FreshFeltMemory  # noqa: E402

#: [deg] fresh felt further than this off the heading counts to its side
SIDE_DEG = 20.0
#: the map's full amount of fresh felt (its amount input's 1, ``lfd_track/policy/memory.py``)
FULL_FRESH = 20.0


class SidesMemory(FreshFeltMemory):
    """The ``fresh_felt`` map with the fresh felt on either side as two more inputs."""

    def __init__(self, config: Any, geometry: Any = None) -> None:
        super().__init__(config, geometry)
        self._sides = np.zeros(2)

    def reset(self) -> None:
        super().reset()
        self._sides = np.zeros(2)

    def _fresh(self, near: np.ndarray, ahead: np.ndarray) -> np.ndarray:
        weights = super()._fresh(near, ahead)
        bearing = np.degrees(np.arctan2(self._points[:, 1], self._points[:, 0]))
        left = float(weights[bearing > SIDE_DEG].sum())
        right = float(weights[bearing < -SIDE_DEG].sum())
        self._sides = np.minimum(1.0, np.array([left, right]) / FULL_FRESH)
        return weights

    def see(self, values: np.ndarray, levels: tuple[float, float] | None = None) -> None:
        super().see(values, levels)
        if self.bearing_deg is None:  # no fresh felt: nothing to either side
            self._sides = np.zeros(2)

    def inputs(self) -> np.ndarray:
        return np.append(super().inputs(), self._sides)


def main() -> None:
    # the two sides swap in a mirror image
    oracle_learner.run_with_more_inputs(
        SidesMemory, 2, lambda sides: sides[:, ::-1], __doc__.splitlines()[0]
    )


if __name__ == "__main__":
    main()
