"""Part 79 of ``README.md``: the map's felt read otherwise than from the whole region's road value
(prototype maps).

Part 78 measured where the goal's map reads felt against the floor's true felt. Two readings a
robot can make from the same frame and the same library, each a prototype map that leaves the
road values (the paper's 40, which nothing here changes) as they are and gives the map its own:

- :class:`CentreWindowMemory` (``--centre-window``): each region's felt is read from the road
  value of the middle of the region only (:data:`WINDOW` of its width and height, about its
  centre, the point the map places it at), against the same library: a region whose centre is
  carpet no longer reads felt because felt fills its edge;
- :class:`HueSatMemory` (``--hue-sat``): each region's felt is read from the similarity of its
  hue and saturation histograms alone (two of the road value's five channels), which a shadow
  darkens less than the red, green and blue ones.

The frame each map reads is the one the road values are read from (colour balanced as the
perception balances it), after the library has learned from it; a frame of another size than
the paper's is read as the perception reads it. Run through ``hairpin_trace.py``; validation
rooms and loops only, nothing here drives a test loop.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import oracle_learner  # noqa: E402

from lfd_track.teaching import perception as perception_module  # noqa: E402
from lfd_track.vision.grid import FRAME_HEIGHT, FRAME_WIDTH, GRID_COLUMNS, GRID_ROWS  # noqa: E402
from lfd_track.vision.histograms import centred_unit  # noqa: E402

#: the share of a region's width and height its middle window spans
WINDOW = 0.5
#: the channels :class:`HueSatMemory` reads (of R, G, B, H, S)
HUE_SAT = (3, 4)

#: the perception perceiving now and the frame it was given (set by the patched ``perceive``)
NOW: dict[str, Any] = {"perception": None, "frame": None}

_perceive = perception_module.Perception.perceive


def _perceive_remembered(self: Any, frame: np.ndarray, box_on_felt: bool | None = None) -> Any:
    NOW["perception"], NOW["frame"] = self, frame
    try:
        return _perceive(self, frame, box_on_felt)
    finally:
        NOW["perception"] = NOW["frame"] = None


def use_frames() -> None:
    """From now on the maps can read the frame the perception is reading."""
    perception_module.Perception.perceive = _perceive_remembered  # type: ignore[method-assign]


def centre_windows(frame: np.ndarray) -> np.ndarray:
    """A frame of the same size whose every region holds its middle window (:data:`WINDOW` of
    its width and height) stretched to the region's size by repeating pixels, so a region's
    histogram is its middle's (the same shares of each bin)."""
    rh, rw = FRAME_HEIGHT // GRID_ROWS, FRAME_WIDTH // GRID_COLUMNS
    wh, ww = int(round(rh * WINDOW)), int(round(rw * WINDOW))
    top, left = (rh - wh) // 2, (rw - ww) // 2
    grid = frame.reshape(GRID_ROWS, rh, GRID_COLUMNS, rw, frame.shape[-1])
    middle = grid[:, top : top + wh, :, left : left + ww]
    rows = np.arange(rh) * wh // rh
    cols = np.arange(rw) * ww // rw
    return middle[:, rows][:, :, :, cols].reshape(frame.shape)


class _FrameReadingMemory(oracle_learner.PrototypeMemory):
    """A map that reads its felt from the frame being perceived (:meth:`_values`)."""

    def see(self, values: np.ndarray, levels: tuple[float, float] | None = None) -> None:
        perception, frame = NOW["perception"], NOW["frame"]
        if (
            perception is None
            or frame is None
            or frame.shape[:2] != (FRAME_HEIGHT, FRAME_WIDTH)
            or not perception.library.n_models
        ):
            super().see(values, levels)
            return
        super().see(self._values(perception, perception._balanced(frame)), levels)

    def _values(self, perception: Any, seen: np.ndarray) -> np.ndarray:
        raise NotImplementedError


class CentreWindowMemory(_FrameReadingMemory):
    """The goal's map reading each region's felt from its middle (see the module docstring)."""

    def _values(self, perception: Any, seen: np.ndarray) -> np.ndarray:
        library = perception.library
        histograms = library.region_histograms(centre_windows(seen))
        return library.road_values_from_histograms(histograms, update_statistics=False)


class HueSatMemory(_FrameReadingMemory):
    """The goal's map reading each region's felt from its hue and saturation alone."""

    def _values(self, perception: Any, seen: np.ndarray) -> np.ndarray:
        library = perception.library
        histograms = library.region_histograms(seen)
        unit, _ = centred_unit(histograms)
        models, _ = centred_unit(library.models())
        corr = np.matmul(unit[list(HUE_SAT)], models[list(HUE_SAT)].transpose(0, 2, 1))
        return np.max(corr.mean(axis=0), axis=1)
