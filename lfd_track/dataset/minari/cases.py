"""A Minari dataset written by lfd-track back to the cases a learner trains on
(:func:`cases_from_minari`), with the road library a controller learned from them drives with.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ...errors import LfdTrackError, first_line
from ...policy.memory import MemoryConfig
from ...vision.road_library import RoadLibrary
from ..checks import _memory_problem, _road_value_problem
from ..records import N_CHANNELS, N_VALUES
from .store import FORMAT, FORMAT_VERSION, METADATA_KEY, open_minari


@dataclass(frozen=True)
class MinariCases:
    """The cases of a Minari dataset, ready for a learner's ``fit(inputs, actions, rng)``."""

    inputs: np.ndarray
    """(N, 40 + m) float64 — road values, then memory inputs."""
    actions: np.ndarray
    """(N,) int8 — the commands, 0 forward, 1 left, 2 right."""
    library: RoadLibrary
    """The road library a controller learned from these cases drives with."""
    memory: MemoryConfig | None
    """The memory settings of the memory inputs (None: none)."""
    dataset_id: str
    n_episodes: int
    recomputed_cases: int
    """Cases whose road values were recomputed with :attr:`library` (recorded with another)."""

    @property
    def n_cases(self) -> int:
        """Number of cases."""
        return int(self.actions.shape[0])


def _carried(dataset: Any, dataset_id: str) -> dict[str, Any]:
    text = dataset.storage.metadata.get(METADATA_KEY)
    if not isinstance(text, str):
        raise LfdTrackError(
            f"Minari dataset {dataset_id}: not written by lfd-track (no '{METADATA_KEY}'"
            " metadata), so it carries no road library to learn with"
        )
    try:
        carried = json.loads(text)
    except ValueError:
        raise LfdTrackError(
            f"Minari dataset {dataset_id}: its '{METADATA_KEY}' metadata is not JSON"
        ) from None
    if not isinstance(carried, dict) or carried.get("format") != FORMAT:
        raise LfdTrackError(f"Minari dataset {dataset_id}: unknown '{METADATA_KEY}' metadata")
    if carried.get("version") != FORMAT_VERSION:
        raise LfdTrackError(
            f"Minari dataset {dataset_id}: written by another lfd-track (format version"
            f" {carried.get('version')!r}, this one reads {FORMAT_VERSION})"
        )
    return carried


def _read_episodes(dataset: Any, where: str) -> Iterator[Any]:
    """The dataset's episodes one by one; a storage that cannot be read is one line."""
    episodes = iter(dataset.iterate_episodes())
    while True:
        try:
            episode = next(episodes)
        except StopIteration:
            return
        except (OSError, KeyError, ValueError, TypeError) as exc:
            raise LfdTrackError(f"{where}: cannot be read ({first_line(exc)})") from None
        yield episode


def cases_from_minari(dataset_id: str, *, datasets_path: str | Path | None = None) -> MinariCases:
    """The cases of the lfd-track Minari dataset ``dataset_id`` and the library to drive with.

    Every episode's observations but its final one are cases, in episode order. See the module
    documentation for the road library. Raises LfdTrackError (one line) on a missing dataset, one
    not written by lfd-track, or one whose content does not fit its metadata.
    """
    dataset = open_minari(dataset_id, datasets_path=datasets_path)
    carried = _carried(dataset, dataset_id)
    where = f"Minari dataset {dataset_id}"
    try:
        files = carried["files"]
        if not isinstance(files, list) or not files:
            raise ValueError("no files")
        libraries = [RoadLibrary.from_dict(f["road_library"]) for f in files]
        library_dicts = [f["road_library"] for f in files]
        origins = [(int(e["file"]), int(e["n_cases"])) for e in carried["episodes"]]
        if any(not 0 <= file < len(files) for file, _ in origins):
            raise ValueError("an episode of no file")
        n_memory = int(carried["n_memory"])
        memory = None if carried["memory"] is None else MemoryConfig.from_dict(carried["memory"])
    except (KeyError, TypeError, ValueError, AttributeError, OverflowError) as exc:
        raise LfdTrackError(f"{where}: bad '{METADATA_KEY}' metadata ({exc})") from None
    if (memory.n_inputs if memory else 0) != n_memory:
        raise LfdTrackError(f"{where}: memory settings do not fit {n_memory} memory inputs")
    library = libraries[0]
    bins = library.bins
    frames = carried.get("observations") == "frames"
    inputs: list[np.ndarray] = []
    actions: list[np.ndarray] = []
    recomputed = 0
    n_episodes = 0
    for episode in _read_episodes(dataset, where):
        index = int(episode.id)
        if not 0 <= index < len(origins):
            raise LfdTrackError(f"{where}: episode {index} is not in its metadata")
        file_index, n_cases = origins[index]
        acts = np.asarray(episode.actions)
        n = acts.shape[0]
        try:
            # A frames dataset carries the recorded road values in its infos.
            obs = np.asarray(
                episode.infos["road_values"] if frames else episode.observations,
                dtype=np.float64,
            )
            hists = np.asarray(episode.infos["histograms"])
            mem = np.asarray(episode.infos["memory"], dtype=np.float64).reshape(n + 1, -1)
        except (KeyError, ValueError):
            raise LfdTrackError(
                f"{where}: episode {index} lacks its"
                f" {'road values, ' if frames else ''}histograms or memory"
            ) from None
        if (
            obs.shape != (n + 1, N_VALUES)
            or hists.shape != (n + 1, N_VALUES, N_CHANNELS, bins)
            or mem.shape[1] != n_memory
            or n != n_cases
            or not np.isin(acts, (0, 1, 2)).all()
        ):
            raise LfdTrackError(f"{where}: episode {index} does not fit its metadata")
        values = obs[:n]
        problem = _road_value_problem(values) or _memory_problem(mem[:n])
        if problem:
            raise LfdTrackError(f"{where}: episode {index}: {problem}")
        if library_dicts[file_index] != library_dicts[0]:
            values = np.array(
                [library.road_values_from_histograms(h, update_statistics=False) for h in hists[:n]]
            )
            recomputed += n
        inputs.append(np.hstack([values, mem[:n]]) if n_memory else values)
        actions.append(acts.astype(np.int8))
        n_episodes += 1
    if not actions:
        raise LfdTrackError(f"{where}: holds no episodes")
    return MinariCases(
        inputs=np.concatenate(inputs),
        actions=np.concatenate(actions),
        library=library,
        memory=memory,
        dataset_id=dataset_id,
        n_episodes=n_episodes,
        recomputed_cases=recomputed,
    )
