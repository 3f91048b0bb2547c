"""The library of known road types (paper §4.2.1, Algorithm 1) and road values (§4.2.2, Alg. 2).

Structure: an ordered list of road *types*, each an ordered list of *examples* (models: five
normalised histograms, see :mod:`lfd_track.vision.histograms`). Order is insertion order; new
types and examples are appended, so a lower index is always older.

Usage statistics: every road-value frame counts 40 region comparisons for every
type and every example present; each region *selects* its most similar example (the first in
order on a tie) and that example's type. A type's counters are its own, kept since the type
entered the library (they survive the eviction of its examples). Selection frequency =
selections / comparisons. Eviction removes the lowest frequency; a type or example never compared
yet is protected (evicted only when nothing else is left, among its peers the oldest); equal
frequencies evict the oldest.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .grid import N_REGIONS, safe_box_slices
from .histograms import (
    N_CHANNELS,
    GridHistogrammer,
    centred_unit,
    check_bins,
    check_frame,
    histogram_means,
    patch_histograms,
    similarity_matrix,
)

LIBRARY_FORMAT_VERSION = 1


@dataclass(frozen=True)
class LearnOutcome:
    """What one step of Algorithm 1 did to the library."""

    type_index: int
    """Index (after the update) of the type the new model now belongs to."""
    new_type: bool
    """True when the model started a new road type."""
    similarity: float | None
    """Best similarity of the new model to the library before the update (None if it was empty)."""
    best_type: int | None
    """Index of the best-matching type before the update (None if the library was empty)."""
    evicted_type: int | None = None
    """Index (before the update) of the road type removed to make room, if any."""
    evicted_example: int | None = None
    """Index within the matched type (before the update) of the example removed, if any."""


@dataclass(frozen=True, eq=False)
class LibraryLearned:
    """Change event: Algorithm 1 stored ``model`` as described by ``outcome``."""

    outcome: LearnOutcome
    model: np.ndarray
    """(5, bins) float32 — the stored model (read-only)."""


@dataclass(frozen=True, eq=False)
class LibrarySelected:
    """Change event: one road-value frame updated the usage counters."""

    per_model: np.ndarray
    """(n_models,) int64 — regions (of 40) that selected each model, in library order."""


LibraryChange = LibraryLearned | LibrarySelected
"""What a library listener receives; replaying the events in order rebuilds the library."""


@dataclass
class _Example:
    model: np.ndarray  # (5, bins) float32
    selections: int = 0
    comparisons: int = 0


@dataclass
class _RoadType:
    examples: list[_Example] = field(default_factory=list)
    selections: int = 0
    comparisons: int = 0


def _least_used(items: Sequence[_Example | _RoadType]) -> int:
    """Index of the least-used item: compared ones first, lowest frequency, then the oldest."""

    def key(indexed: tuple[int, _Example | _RoadType]) -> tuple[bool, float, int]:
        i, item = indexed
        if item.comparisons == 0:
            return (True, 0.0, i)
        return (False, item.selections / item.comparisons, i)

    return min(enumerate(items), key=key)[0]


class RoadLibrary:
    """Road types learned from the safe box; turns frames into 40 road values.

    Args:
        bins: histogram bins per channel (1..256; the paper does not say, 32 by default).
        similarity_threshold: a new model joins the best type only if similarity > this (strict).
        max_types: most road types kept (the paper's 10).
        max_examples: most examples per type (the paper's 10).
    """

    def __init__(
        self,
        bins: int = 32,
        similarity_threshold: float = 0.75,
        max_types: int = 10,
        max_examples: int = 10,
    ) -> None:
        self.bins = check_bins(bins)
        threshold: object = similarity_threshold  # checked as whatever the caller passed
        if isinstance(threshold, bool | np.bool_) or not isinstance(threshold, numbers.Real):
            raise ValueError(f"similarity_threshold must be a number in [-1, 1], got {threshold!r}")
        try:
            finite = math.isfinite(threshold)
        except OverflowError:  # an integer beyond any float
            raise ValueError(
                "similarity_threshold must be in [-1, 1], got a huge integer"
            ) from None
        if not finite or not -1.0 <= float(threshold) <= 1.0:
            raise ValueError(f"similarity_threshold must be in [-1, 1], got {threshold}")
        for name, value in (("max_types", max_types), ("max_examples", max_examples)):
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
                raise ValueError(f"{name} must be a positive integer, got {value!r}")
        self.similarity_threshold = float(similarity_threshold)
        self.max_types = int(max_types)
        self.max_examples = int(max_examples)
        self._types: list[_RoadType] = []
        self._grid = GridHistogrammer(self.bins)
        self._cache: tuple[tuple[np.ndarray, np.ndarray], np.ndarray] | None = None
        # model_means() and the _cache it was computed with.
        self._means: tuple[object, np.ndarray] | None = None
        # Counter updates of road-value frames not yet written into the types and examples:
        # how many frames, and the regions each model won over them (model order). Written
        # before anything reads the counters or changes the models.
        self._pending_frames = 0
        self._pending_selected: np.ndarray | None = None
        self._listeners: list[Callable[[LibraryChange], None]] = []

    # ----------------------------------------------------------------------------- listeners
    def subscribe(self, listener: Callable[[LibraryChange], None]) -> Callable[[], None]:
        """Call ``listener`` after every change (learning step, counter update); returns an
        unsubscribe function. A recorder uses this to log the library incrementally."""
        self._listeners.append(listener)

        def unsubscribe() -> None:
            if listener in self._listeners:
                self._listeners.remove(listener)

        return unsubscribe

    def _notify(self, change: LibraryChange) -> None:
        for listener in list(self._listeners):
            listener(change)

    def redo_learned(
        self,
        model: np.ndarray,
        *,
        joined_type: int | None,
        evicted_type: int | None,
        evicted_example: int | None,
    ) -> None:
        """Apply a recorded learning step without re-running Algorithm 1's similarity test.

        ``joined_type`` is the type the model joined (None: it started a new type); the evicted
        indices are as in :class:`LearnOutcome`. Raises ``ValueError`` if the step is impossible
        for this library (wrong index, eviction missing or not needed).
        """
        model = self._check_model(model)
        self._write_counts()
        if joined_type is None:
            full = len(self._types) >= self.max_types
            if evicted_example is not None or full != (evicted_type is not None):
                raise ValueError("new-type step does not match the library's fill")
            if evicted_type is not None:
                if not 0 <= evicted_type < len(self._types):
                    raise ValueError(f"evicted type {evicted_type} does not exist")
                del self._types[evicted_type]
            self._types.append(_RoadType(examples=[_Example(model)]))
        else:
            if evicted_type is not None or not 0 <= joined_type < len(self._types):
                raise ValueError(f"joined type {joined_type} does not exist")
            examples = self._types[joined_type].examples
            full = len(examples) >= self.max_examples
            if full != (evicted_example is not None):
                raise ValueError("join step does not match the type's fill")
            if evicted_example is not None:
                if not 0 <= evicted_example < len(examples):
                    raise ValueError(f"evicted example {evicted_example} does not exist")
                del examples[evicted_example]
            examples.append(_Example(model))
        self._cache = None

    def redo_selected(self, per_model: np.ndarray) -> None:
        """Apply a recorded counter update: (n_models,) regions that selected each model."""
        counts = np.asarray(per_model)
        if counts.shape != (self.n_models,) or not np.issubdtype(counts.dtype, np.integer):
            raise ValueError(f"selection counts must be {self.n_models} integers")
        if self.n_models == 0 or counts.min() < 0 or int(counts.sum()) != N_REGIONS:
            raise ValueError(f"selection counts must be >= 0 and sum to {N_REGIONS}")
        self._add_selections(counts.astype(np.int64), notify=False)

    # ----------------------------------------------------------------------------- inspection
    @property
    def n_types(self) -> int:
        """Number of road types."""
        return len(self._types)

    @property
    def n_models(self) -> int:
        """Number of stored models (examples over all types)."""
        return sum(len(t.examples) for t in self._types)

    def type_sizes(self) -> list[int]:
        """Number of examples of each type, in order."""
        return [len(t.examples) for t in self._types]

    def models(self) -> np.ndarray:
        """All stored models in library order (type by type), (n_models, 5, bins) float32."""
        if not self._types:
            return np.zeros((0, N_CHANNELS, self.bins), dtype=np.float32)
        return np.stack([e.model for t in self._types for e in t.examples])

    def model_means(self) -> np.ndarray:
        """Mean R, G, B level of each model's histograms (:func:`histogram_means`), (n_models, 3)
        float64, read-only: the same array until the models change (kept with the prepared
        models Algorithm 2 compares with)."""
        prepared = self._stacked()
        if self._means is None or self._means[0] is not prepared:
            means = histogram_means(self.models())
            means.flags.writeable = False
            self._means = (prepared, means)
        return self._means[1]

    def type_statistics(self) -> list[tuple[int, int]]:
        """``(selections, comparisons)`` of each type, in order."""
        self._write_counts()
        return [(t.selections, t.comparisons) for t in self._types]

    def example_statistics(self, type_index: int) -> list[tuple[int, int]]:
        """``(selections, comparisons)`` of each example of one type, in order."""
        self._write_counts()
        return [(e.selections, e.comparisons) for e in self._types[type_index].examples]

    # ----------------------------------------------------------------------------- histograms
    def safe_box_model(self, frame: np.ndarray) -> np.ndarray:
        """Model of the safe box of an RGB uint8 (480, 640, 3) frame (or a smaller camera's: its
        safe box is at the same place on the floor, :func:`~lfd_track.core.frame.safe_box`),
        (5, bins) float32."""
        check_frame(frame)
        rows, cols = safe_box_slices(frame.shape[1], frame.shape[0])
        return patch_histograms(frame[rows, cols], self.bins)

    def region_histograms(self, frame: np.ndarray) -> np.ndarray:
        """Normalised histograms of the 8 x 5 regions, (40, 5, bins) float32, row-major."""
        return self._grid.histograms(frame)

    # ----------------------------------------------------------------------------- Algorithm 1
    def learn(self, frame: np.ndarray) -> LearnOutcome:
        """Algorithm 1 on the safe box of an RGB uint8 (480, 640, 3) frame."""
        return self.learn_model(self.safe_box_model(frame))

    def learn_model(self, model: np.ndarray) -> LearnOutcome:
        """Algorithm 1 with a precomputed model, (5, bins) float (stored as float32).

        The model joins the type of its most similar example (first in order on a tie) when that
        similarity is > ``similarity_threshold``; the type's least-used example is evicted first
        if it is full. Otherwise it starts a new type, appended after evicting the least-used type
        if the library is full. Learning does not change usage statistics.
        """
        model = self._check_model(model)
        self._write_counts()
        similarity: float | None = None
        best_type: int | None = None
        if self._types:
            prepared, owners = self._stacked()
            sims = similarity_matrix(centred_unit(model[None]), prepared)[0]
            best = int(np.argmax(sims))  # first maximum = first in library order
            similarity = float(sims[best])
            best_type = int(owners[best])
        if (
            best_type is not None
            and similarity is not None
            and (
                similarity > self.similarity_threshold  # strict, as in the paper
            )
        ):
            road_type = self._types[best_type]
            evicted_example = None
            if len(road_type.examples) >= self.max_examples:
                evicted_example = _least_used(road_type.examples)
                del road_type.examples[evicted_example]
            road_type.examples.append(_Example(model))
            self._cache = None
            outcome = LearnOutcome(
                type_index=best_type,
                new_type=False,
                similarity=similarity,
                best_type=best_type,
                evicted_example=evicted_example,
            )
            self._notify_learned(outcome, model)
            return outcome
        evicted_type = None
        if len(self._types) >= self.max_types:
            evicted_type = _least_used(self._types)
            del self._types[evicted_type]
        self._types.append(_RoadType(examples=[_Example(model)]))
        self._cache = None
        outcome = LearnOutcome(
            type_index=len(self._types) - 1,
            new_type=True,
            similarity=similarity,
            best_type=best_type,
            evicted_type=evicted_type,
        )
        self._notify_learned(outcome, model)
        return outcome

    def _notify_learned(self, outcome: LearnOutcome, model: np.ndarray) -> None:
        if self._listeners:
            frozen = model.copy()
            frozen.flags.writeable = False
            self._notify(LibraryLearned(outcome, frozen))

    # ----------------------------------------------------------------------------- Algorithm 2
    def road_values(self, frame: np.ndarray, *, update_statistics: bool = True) -> np.ndarray:
        """Algorithm 2: best similarity of each region to any stored model, (40,) float64.

        ``frame``: RGB uint8 (480, 640, 3). Regions are 80 x 96 px (an eighth of the width and a
        fifth of the height of a smaller camera's frame), row-major from the top-left.
        Values lie in [-1, 1]; an empty library gives all zeros.
        """
        return self.road_values_from_histograms(
            self.region_histograms(frame), update_statistics=update_statistics
        )

    def road_values_from_histograms(
        self, hists: np.ndarray, *, update_statistics: bool = True
    ) -> np.ndarray:
        """Algorithm 2 from region histograms, (40, 5, bins) → (40,) float64.

        With ``update_statistics=False`` the library is left untouched (e.g. to recompute the
        values of recorded frames against a finished library).
        """
        hists = np.asarray(hists)
        if hists.shape != (N_REGIONS, N_CHANNELS, self.bins):
            raise ValueError(
                f"region histograms must have shape ({N_REGIONS}, {N_CHANNELS}, {self.bins}),"
                f" got {hists.shape}"
            )
        if not self._types:
            return np.zeros(N_REGIONS, dtype=np.float64)
        prepared, owners = self._stacked()
        sims = similarity_matrix(centred_unit(hists), prepared)  # (40, n_models)
        best = np.argmax(sims, axis=1)  # first maximum wins a tie, as the strict '>' loop does
        values = sims[np.arange(N_REGIONS), best]
        if update_statistics:
            self._count_selections(best, len(owners))
        return values

    def _count_selections(self, best: np.ndarray, n_models: int) -> None:
        self._add_selections(np.bincount(best, minlength=n_models))

    def _add_selections(self, per_model: np.ndarray, *, notify: bool = True) -> None:
        per_model = np.asarray(per_model, dtype=np.int64)
        if self._pending_selected is None:
            self._pending_selected = per_model.copy()
        else:
            self._pending_selected += per_model
        self._pending_frames += 1
        if notify and self._listeners:
            counts = np.array(per_model, dtype=np.int64)
            counts.flags.writeable = False
            self._notify(LibrarySelected(counts))

    def _write_counts(self) -> None:
        """Add the pending frames' comparisons and selections to the types and examples."""
        if not self._pending_frames:
            return
        compared = N_REGIONS * self._pending_frames
        selected = self._pending_selected
        self._pending_frames, self._pending_selected = 0, None
        assert selected is not None
        counts = iter(selected.tolist())  # model order: type by type, example by example
        for t in self._types:
            t.comparisons += compared
            for e in t.examples:
                n = next(counts)
                e.comparisons += compared
                e.selections += n
                t.selections += n

    # ----------------------------------------------------------------------------- internals
    def _check_model(self, model: np.ndarray) -> np.ndarray:
        model = np.asarray(model)
        if model.shape != (N_CHANNELS, self.bins):
            raise ValueError(
                f"model must have shape ({N_CHANNELS}, {self.bins}), got {model.shape}"
            )
        if not np.all(np.isfinite(model)):
            raise ValueError("model contains NaN or infinite values")
        return np.array(model, dtype=np.float32, copy=True)

    def _stacked(self) -> tuple[tuple[np.ndarray, np.ndarray], np.ndarray]:
        """Prepared models (see ``centred_unit``) and the owning type index of each, cached."""
        if self._cache is None:
            owners = np.array(
                [i for i, t in enumerate(self._types) for _ in t.examples], dtype=np.intp
            )
            self._cache = (centred_unit(self.models()), owners)
        return self._cache

    # ----------------------------------------------------------------------------- persistence
    def to_dict(self) -> dict[str, Any]:
        """Lossless JSON-friendly snapshot: settings, structure, models and usage counters.

        Models are float32; each value is written as the Python float of that float32, which
        reads back to the identical float32.
        """
        self._write_counts()
        return {
            "version": LIBRARY_FORMAT_VERSION,
            "bins": self.bins,
            "similarity_threshold": self.similarity_threshold,
            "max_types": self.max_types,
            "max_examples": self.max_examples,
            "types": [
                {
                    "selections": t.selections,
                    "comparisons": t.comparisons,
                    "examples": [
                        {
                            "selections": e.selections,
                            "comparisons": e.comparisons,
                            "model": e.model.astype(np.float64).tolist(),
                        }
                        for e in t.examples
                    ],
                }
                for t in self._types
            ],
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> RoadLibrary:
        """Rebuild a library from :meth:`to_dict` output; ``ValueError`` names what is wrong."""
        if not isinstance(data, dict):
            raise ValueError("road library must be a JSON object")
        expected = {"version", "bins", "similarity_threshold", "max_types", "max_examples", "types"}
        missing = sorted(expected - set(data))
        if missing:
            raise ValueError(f"road library is missing key '{missing[0]}'")
        unknown = sorted(set(data) - expected)
        if unknown:
            raise ValueError(f"road library has unknown key '{unknown[0]}'")
        if data["version"] != LIBRARY_FORMAT_VERSION:
            raise ValueError(
                f"road library version {data['version']!r} is not supported"
                f" (expected {LIBRARY_FORMAT_VERSION})"
            )
        threshold = data["similarity_threshold"]
        if isinstance(threshold, bool) or not isinstance(threshold, (int, float)):
            raise ValueError("road library similarity_threshold must be a number")
        if isinstance(threshold, int) and abs(threshold) > 1:  # also too big for a float
            raise ValueError("road library similarity_threshold must lie in [-1, 1]")
        library = cls(
            bins=data["bins"],
            similarity_threshold=float(threshold),
            max_types=data["max_types"],
            max_examples=data["max_examples"],
        )
        types = data["types"]
        if not isinstance(types, list) or len(types) > library.max_types:
            raise ValueError(f"road library 'types' must be a list of at most {library.max_types}")
        for i, t in enumerate(types):
            where = f"road library type {i}"
            if not isinstance(t, dict) or set(t) != {"selections", "comparisons", "examples"}:
                raise ValueError(f"{where} must have exactly selections, comparisons, examples")
            examples = t["examples"]
            if not isinstance(examples, list) or not 1 <= len(examples) <= library.max_examples:
                raise ValueError(f"{where} must have 1..{library.max_examples} examples")
            road_type = _RoadType(
                selections=_count(t["selections"], where),
                comparisons=_count(t["comparisons"], where),
            )
            if road_type.selections > road_type.comparisons:
                raise ValueError(f"{where}: more selections than comparisons")
            for j, e in enumerate(examples):
                ewhere = f"{where} example {j}"
                if not isinstance(e, dict) or set(e) != {"selections", "comparisons", "model"}:
                    raise ValueError(f"{ewhere} must have exactly selections, comparisons, model")
                try:
                    model = np.asarray(e["model"], dtype=np.float64)
                except (TypeError, ValueError, OverflowError):
                    raise ValueError(f"{ewhere} model must be numbers") from None
                # Range first, in double precision: a value beyond float32 would otherwise
                # become infinite (with a warning) in the float32 copy.
                if model.size and (model.min() < 0.0 or model.max() > 1.0):
                    raise ValueError(f"{ewhere}: histogram values must lie in [0, 1]")
                try:
                    model = library._check_model(model)
                except ValueError as exc:
                    raise ValueError(f"{ewhere}: {exc}") from None
                example = _Example(
                    model=model,
                    selections=_count(e["selections"], ewhere),
                    comparisons=_count(e["comparisons"], ewhere),
                )
                if example.selections > example.comparisons:
                    raise ValueError(f"{ewhere}: more selections than comparisons")
                road_type.examples.append(example)
            library._types.append(road_type)
        return library

    def __repr__(self) -> str:
        return (
            f"RoadLibrary(bins={self.bins}, types={self.n_types}, models={self.n_models},"
            f" threshold={self.similarity_threshold})"
        )


_MAX_COUNT = 2**62  # far beyond any run (40 comparisons per frame), and exact in int64


def _count(value: Any, where: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= _MAX_COUNT:
        raise ValueError(
            f"{where}: counters must be non-negative integers up to 2**62, got {value!r}"
        )
    return value
