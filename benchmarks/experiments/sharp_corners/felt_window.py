"""Part 79 of ``README.md``: the map's felt read from a region's middle, or from hue and saturation.

Prototype maps that read felt otherwise than from the whole region's road value.

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

from lfd_track.vision.grid import FRAME_HEIGHT, FRAME_WIDTH, GRID_COLUMNS, GRID_ROWS  # noqa: E402
from lfd_track.vision.histograms import centred_unit  # noqa: E402
from lfd_track.vision.road_library import RoadLibrary  # noqa: E402

#: the share of a region's width and height its middle window spans
WINDOW = 0.5
#: the channels :class:`HueSatMemory` reads (of R, G, B, H, S)
HUE_SAT = (3, 4)

#: the library that last read a frame's regions, that frame (colour balanced as the perception
#: balances it) and its region histograms, set by the patched ``RoadLibrary.region_histograms``:
#: the perception reads the frame's regions just before the map sees its road values
NOW: dict[str, Any] = {"library": None, "frame": None, "histograms": None}

_region_histograms = RoadLibrary.region_histograms


def _region_histograms_remembered(self: RoadLibrary, frame: np.ndarray) -> np.ndarray:
    histograms = _region_histograms(self, frame)
    NOW["library"], NOW["frame"], NOW["histograms"] = self, frame, histograms
    return histograms


def use_frames() -> None:
    """From now on the maps can read the frame the perception read its road values from."""
    RoadLibrary.region_histograms = _region_histograms_remembered  # type: ignore[method-assign]


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
        library, frame, histograms = NOW["library"], NOW["frame"], NOW["histograms"]
        NOW["library"] = NOW["frame"] = NOW["histograms"] = None  # read once, by this frame
        if (
            library is None
            or frame is None
            or frame.shape[:2] != (FRAME_HEIGHT, FRAME_WIDTH)
            or not library.n_models
        ):
            super().see(values, levels)
            return
        super().see(self._values(library, frame, histograms), levels)

    @staticmethod
    def prepare() -> None:
        """What the map needs before it runs (``hairpin_trace.py`` calls it): the frames."""
        use_frames()

    def _values(self, library: RoadLibrary, seen: np.ndarray, histograms: np.ndarray) -> np.ndarray:
        """The 40 road values the map reads felt from: of the frame ``seen``, whose region
        histograms ``library`` read as ``histograms``."""
        raise NotImplementedError


class CentreWindowMemory(_FrameReadingMemory):
    """The goal's map reading each region's felt from its middle (see the module docstring)."""

    def _values(self, library: RoadLibrary, seen: np.ndarray, histograms: np.ndarray) -> np.ndarray:
        middles = _region_histograms(library, centre_windows(seen))
        return library.road_values_from_histograms(middles, update_statistics=False)


class HueSatMemory(_FrameReadingMemory):
    """The goal's map reading each region's felt from its hue and saturation alone."""

    def _values(self, library: RoadLibrary, seen: np.ndarray, histograms: np.ndarray) -> np.ndarray:
        unit, _ = centred_unit(histograms)
        models, _ = centred_unit(library.models())
        corr = np.matmul(unit[list(HUE_SAT)], models[list(HUE_SAT)].transpose(0, 2, 1))
        return np.max(corr.mean(axis=0), axis=1)


def main() -> None:
    """Run a study (``--study``, ``--out``, ``--seed``) with every ``fresh_felt`` map a
    :class:`CentreWindowMemory`, or with ``--hue-sat`` a :class:`HueSatMemory`."""
    memory_class: type[_FrameReadingMemory] = CentreWindowMemory
    if "--hue-sat" in sys.argv:
        sys.argv.remove("--hue-sat")
        memory_class = HueSatMemory
    memory_class.prepare()
    oracle_learner.run_with_map(memory_class, __doc__.splitlines()[0])


if __name__ == "__main__":
    main()
