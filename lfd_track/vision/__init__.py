"""Vision: RGBHS histograms, the road library (Algorithm 1), road values (Algorithm 2), overlay."""

from .grid import N_REGIONS, SAFE_BOX
from .road_library import LearnOutcome, RoadLibrary

__all__ = ["N_REGIONS", "SAFE_BOX", "LearnOutcome", "RoadLibrary"]
