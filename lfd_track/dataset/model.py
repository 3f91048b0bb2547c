"""A loaded demonstration: the cases as read-only arrays, one row per case, and the metadata."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..core.commands import Command
from ..policy.features import DEFAULT_FEATURES, check_features, frame_features
from ..policy.memory import MemoryConfig
from ..vision.road_library import RoadLibrary
from .records import SOURCES

__all__ = ["SOURCES", "Demonstration"]

# Keys the loader derives; stored metadata never overrides them.
_DERIVED_KEYS = (
    "complete",
    "n_cases",
    "counts",
    "torn_tail_bytes",
    "schema_version",
    "bins",
    "library_log",
)


@dataclass(frozen=True, eq=False)
class Demonstration:
    """A loaded demonstration; arrays are read-only, one row per recorded case."""

    commands: np.ndarray
    """(N,) int8 — 0 forward, 1 left, 2 right."""
    road_values: np.ndarray
    """(N, 40) float64 — record-time road values, row-major from the top-left region."""
    histograms: np.ndarray
    """(N, 40, 5, bins) float32 — region histograms (R, G, B, H, S) the values came from."""
    poses: np.ndarray
    """(N, 3) float64 — (x [m], y [m], theta [rad]) when known (simulation), else NaN."""
    progress_m: np.ndarray
    """(N,) float64 — progress along the driven centreline [m]; NaN on hardware."""
    phases: np.ndarray
    """(N,) str — phase label, e.g. "library_only", "drive", "turnaround"."""
    learned: np.ndarray
    """(N,) bool — whether the road library learned from this frame."""
    steps: np.ndarray
    """(N,) int64 — the recorder's step index of each case."""
    sources: np.ndarray
    """(N,) str — ``"demonstration"`` or ``"correction"`` (see :data:`SOURCES`)."""
    rounds: np.ndarray
    """(N,) int64 — 0 for the initial demonstration, r for the r-th round of interventions."""
    metadata: dict[str, Any] = field(default_factory=dict)
    """File-level metadata: header metadata, footer metadata and derived keys (see module doc)."""
    memory: np.ndarray | None = None
    """(N, m) float64 — the policy's memory inputs at each case (m = 0 without memory)."""

    def __post_init__(self) -> None:
        if self.memory is None:
            empty = np.zeros((self.commands.shape[0], 0), dtype=np.float64)
            empty.flags.writeable = False
            object.__setattr__(self, "memory", empty)

    @property
    def inputs(self) -> np.ndarray:
        """(N, 40 + m) float64 — what the policy read: road values, then memory inputs."""
        assert self.memory is not None
        if not self.memory.shape[1]:
            return self.road_values
        return np.hstack([self.road_values, self.memory])

    def policy_inputs(self, features: str = DEFAULT_FEATURES) -> np.ndarray:
        """(N, f + m) float64 — what a policy reading the per-region ``features``
        (:mod:`lfd_track.policy.features`) reads: the road values, then the colour features
        computed from the stored histograms (``"road_values+colour"``, exactly as when driving),
        then the memory inputs. With the default features this is :attr:`inputs`."""
        if check_features(features) == DEFAULT_FEATURES:
            return self.inputs
        assert self.memory is not None
        if features == "none":
            return self.memory
        return np.hstack([frame_features(self.road_values, self.histograms, features), self.memory])

    @property
    def n_cases(self) -> int:
        """Number of recorded cases."""
        return int(self.commands.shape[0])

    @property
    def bins(self) -> int:
        """Histogram bins per channel."""
        return int(self.histograms.shape[-1])

    @property
    def command_counts(self) -> dict[str, int]:
        """Cases per command, keyed by lower-case command name (forward, left, right)."""
        counts = np.bincount(self.commands.astype(np.int64), minlength=len(Command))
        return {c.name.lower(): int(counts[c]) for c in Command}

    def road_library(self) -> RoadLibrary:
        """The road library as it was when recording ended (the one to drive with).

        Raises ValueError if the file stores none (a recording that was interrupted) or a bad one.
        """
        data = self.metadata.get("road_library")
        if not isinstance(data, dict):
            raise ValueError("no road library stored (recording was interrupted?)")
        try:
            return RoadLibrary.from_dict(data)
        except (ValueError, KeyError, TypeError) as exc:
            raise ValueError(f"bad road library ({exc})") from None

    def memory_settings(self) -> MemoryConfig | None:
        """The memory settings the cases' memory inputs were recorded with (None: no memory).

        Raises ValueError if the stored settings are bad or do not fit the cases' memory inputs.
        """
        assert self.memory is not None
        n_memory = self.memory.shape[1]
        settings = self.metadata.get("memory")
        if settings is None and n_memory == 0:
            return None
        try:
            memory = MemoryConfig.from_dict(settings)
        except ValueError as exc:
            raise ValueError(f"bad memory settings ({exc})") from None
        if memory.n_inputs != n_memory:
            raise ValueError(
                f"memory settings '{memory.kind}' need {memory.n_inputs} memory inputs per case,"
                f" the cases hold {n_memory}"
            )
        return memory


def _counts(commands: list[int] | np.ndarray) -> dict[str, int]:
    counts = np.bincount(np.asarray(commands, dtype=np.int64), minlength=len(Command))
    return {c.name.lower(): int(counts[c]) for c in Command}
