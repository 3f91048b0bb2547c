"""Recordings to a Minari dataset: :func:`export_minari`, episodes cut from the recorded steps,
camera frames from a replay of a scripted drive (the layout is in :mod:`lfd_track.dataset.minari`).
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ...errors import LfdTrackError, first_line
from ...utils.outputs import shown_path
from ...vision.road_library import RoadLibrary
from ..model import Demonstration
from ..reader import load_demonstration, load_for_learning
from ..records import SOURCES
from .store import (
    ENV_ID,
    FORMAT,
    FORMAT_VERSION,
    METADATA_KEY,
    OBSERVATIONS,
    check_dataset_id,
    datasets_root,
    minari_root,
)

_NO_FRAMES = (
    "--observations frames needs a scripted demonstration (lfd-track demo), whose drive is"
    " replayed from its seed: a .lfdemo recording stores road values and region histograms, not"
    " camera frames, and this one {why}; use --observations road-values"
)
#: Largest difference between a replayed and a recorded road value that still counts as the same
#: drive (the replay runs the same code; only BLAS's last bits may differ between machines).
_REPLAY_TOLERANCE = 1e-9


def _replayed_frames(rec: _Recording) -> dict[int, np.ndarray]:
    """The camera frame of every recorded case of a scripted demonstration, by step, from a
    replay of its drive; one line when the recording is not one or the replay differs."""
    from ...core.config import config_from_dict
    from ...demo.demonstrator import HumanConfig, run_demonstration
    from ...vision.road_library import RoadLibrary

    demo, name = rec.demo, shown_path(rec.path)
    meta = demo.metadata
    seed, human = meta.get("seed"), meta.get("human")
    if not isinstance(seed, int) or isinstance(seed, bool) or not isinstance(human, dict):
        raise LfdTrackError(f"{name}: " + _NO_FRAMES.format(why="records no scripted human"))
    if set(demo.sources.tolist()) != {"demonstration"} or set(demo.rounds.tolist()) != {0}:
        raise LfdTrackError(
            f"{name}: " + _NO_FRAMES.format(why="holds corrections or rounds beyond the drive")
        )
    try:
        config = config_from_dict(HumanConfig, human, "human")
    except ValueError as exc:
        raise LfdTrackError(f"{name}: bad human settings ({first_line(exc)})") from None
    frames: dict[int, np.ndarray] = {}
    bins = demo.bins
    with tempfile.TemporaryDirectory() as tmp:
        again = Path(tmp) / "replay.lfdemo"
        run_demonstration(
            again,
            seed=seed,
            track=meta["track"],
            preset=meta.get("preset", "paper"),
            human=config,
            library_factory=lambda: RoadLibrary(bins=bins),
            fsync=False,
            memory=demo.memory_settings(),
            frames=lambda step, frame: frames.__setitem__(step, frame.copy()),
        )
        replay = load_demonstration(again)
    same = (
        replay.n_cases == demo.n_cases
        and np.array_equal(replay.commands, demo.commands)
        and np.array_equal(replay.steps, demo.steps)
        and np.allclose(replay.road_values, demo.road_values, rtol=0, atol=_REPLAY_TOLERANCE)
        and all(int(s) in frames for s in demo.steps)
    )
    if not same:
        raise LfdTrackError(
            f"{name}: replaying its drive from seed {seed} does not give the recorded commands"
            " and road values (recorded by another lfd-track version, or changed), so its frames"
            " cannot be exported; use --observations road-values"
        )
    return frames


@dataclass(frozen=True)
class _Recording:
    path: Path
    demo: Demonstration
    library: RoadLibrary


def _read_recording(path: Path) -> _Recording:
    """Load one file with the checks ``lfd-track evolve`` makes (one line on a problem)."""
    demo, library, _ = load_for_learning(path)
    name = shown_path(path)
    meta = demo.metadata
    kind = meta.get("kind")
    if kind != "simulated":
        what = f"a {kind} recording" if isinstance(kind, str) else "not a simulated recording"
        raise LfdTrackError(f"{name}: {what}, not a drive in {ENV_ID} (no env to recover)")
    if not isinstance(meta.get("track"), str):
        raise LfdTrackError(f"{name}: records no track, so its {ENV_ID} cannot be recovered")
    if not isinstance(meta.get("preset", "paper"), str):
        raise LfdTrackError(f"{name}: its preset is not a name or a path")
    return _Recording(path, demo, library)


def _episode_bounds(demo: Demonstration) -> list[tuple[int, int]]:
    """[start, end) case ranges of consecutive steps of one round."""
    steps = demo.steps.astype(np.int64)
    rounds = demo.rounds.astype(np.int64)
    cut = np.flatnonzero((np.diff(steps) != 1) | (np.diff(rounds) != 0)) + 1
    edges = [0, *cut.tolist(), demo.n_cases]
    return list(zip(edges[:-1], edges[1:], strict=True))


def _episode_buffer(
    demo: Demonstration,
    start: int,
    end: int,
    episode_id: int,
    phases: list[str],
    frames: dict[int, np.ndarray] | None = None,
) -> Any:
    from minari.data_collector import EpisodeBuffer

    n = end - start
    with_final = np.r_[np.arange(start, end), end - 1]  # the final observation repeats the last
    observations = np.array(demo.road_values[with_final], dtype=np.float64)
    if frames is not None:
        observations = np.stack([frames[int(demo.steps[i])] for i in with_final])
    final = n  # index of the final observation
    histograms = np.array(demo.histograms[with_final], dtype=np.float32)
    histograms[final] = 0.0
    assert demo.memory is not None  # set to (N, 0) by Demonstration when absent
    memory = np.array(demo.memory[with_final], dtype=np.float64)
    memory[final] = 0.0
    pose = np.array(demo.poses[with_final], dtype=np.float64)
    pose[final] = np.nan
    progress = np.array(demo.progress_m[with_final], dtype=np.float64)
    progress[final] = np.nan
    sources = np.array([SOURCES.index(s) for s in demo.sources[with_final]], dtype=np.int64)
    phase = np.array([phases.index(p) for p in demo.phases[start:end]] + [-1], dtype=np.int64)
    infos = {
        "case": np.r_[np.arange(start, end), -1].astype(np.int64),
        "step": np.r_[demo.steps[start:end], demo.steps[end - 1] + 1].astype(np.int64),
        "pose": pose,
        "progress_m": progress,
        "learned": np.r_[demo.learned[start:end], False].astype(np.bool_),
        "phase": phase,
        "source": sources,
        "round": demo.rounds[with_final].astype(np.int64),
        "histograms": histograms,
        "memory": memory,
    }
    if frames is not None:
        values = np.array(demo.road_values[with_final], dtype=np.float64)
        values[final] = 0.0
        infos["road_values"] = values
    truncations = np.zeros(n, dtype=np.bool_)
    truncations[-1] = True
    return EpisodeBuffer(
        id=episode_id,
        observations=observations,
        actions=np.array(demo.commands[start:end], dtype=np.int64),
        rewards=np.zeros(n, dtype=np.float64),
        terminations=np.zeros(n, dtype=np.bool_),
        truncations=truncations,
        infos=infos,
    )


def _env(recording: _Recording, observations: str = "road-values") -> Any:
    import gymnasium as gym

    from ...envs.library_observation import LibraryRoadValueObservation
    from ...envs.registration import register_envs

    register_envs()
    meta = recording.demo.metadata
    env = gym.make(ENV_ID, track=meta["track"], preset=meta.get("preset", "paper"))
    if observations == "frames":
        return env
    return LibraryRoadValueObservation(env, recording.library.to_dict())


def export_minari(
    demos: Sequence[str | Path],
    dataset_id: str,
    *,
    observations: str = "road-values",
    datasets_path: str | Path | None = None,
    force: bool = False,
) -> Path:
    """Write the recordings ``demos`` as the Minari dataset ``dataset_id``; return its folder.

    ``datasets_path`` None means Minari's own datasets folder. An existing dataset of that id is
    replaced only with ``force``, and only once the new one is complete. The recordings must be
    simulated drives on one track and preset, with the same histogram bins and memory settings.

    Raises:
        LfdTrackError: one line naming the file or dataset and the problem (bad or unsuitable
            recording, dataset exists, frames asked for, the minari extra missing).
    """
    if observations not in OBSERVATIONS:
        raise LfdTrackError(
            f"observations must be one of {', '.join(OBSERVATIONS)}, got {observations!r}"
        )
    namespace = check_dataset_id(dataset_id)
    root = datasets_root(datasets_path)
    if root.exists() and not root.is_dir():
        raise LfdTrackError(f"{shown_path(root)}: the Minari datasets folder is not a folder")
    target = root / dataset_id
    if target.exists() and not force:
        raise LfdTrackError(
            f"Minari dataset {dataset_id} already exists in {shown_path(root)}"
            " (use --force to replace it)"
        )
    if not demos:
        raise LfdTrackError("no demonstration files given")
    recordings = [_read_recording(Path(p)) for p in demos]
    first = recordings[0]
    for rec in recordings[1:]:
        for what, mine, theirs in (
            ("track", rec.demo.metadata["track"], first.demo.metadata["track"]),
            ("preset", rec.demo.metadata.get("preset"), first.demo.metadata.get("preset")),
            ("histogram bins", rec.demo.bins, first.demo.bins),
            ("memory settings", rec.demo.metadata.get("memory"), first.demo.metadata.get("memory")),
        ):
            if mine != theirs:
                raise LfdTrackError(
                    f"{shown_path(rec.path)}: {what} {mine!r}, but {shown_path(first.path)}"
                    f" has {theirs!r} (a dataset is of one env)"
                )

    phases = sorted({str(p) for rec in recordings for p in rec.demo.phases})
    buffers: list[Any] = []  # minari.data_collector.EpisodeBuffer (the extra, imported late)
    files = []
    episodes = []
    for index, rec in enumerate(recordings):
        frames = _replayed_frames(rec) if observations == "frames" else None
        for start, end in _episode_bounds(rec.demo):
            buffers.append(_episode_buffer(rec.demo, start, end, len(buffers), phases, frames))
            episodes.append({"file": index, "first_case": start, "n_cases": end - start})
        files.append(
            {
                "name": rec.path.name,
                "metadata": {
                    k: v for k, v in rec.demo.metadata.items() if k not in ("road_library",)
                },
                "road_library": rec.library.to_dict(),
            }
        )
    assert first.demo.memory is not None  # set to (N, 0) by Demonstration when absent
    n_memory = int(first.demo.memory.shape[1])
    carried = {
        "format": FORMAT,
        "version": FORMAT_VERSION,
        "observations": observations,
        "bins": first.demo.bins,
        "n_memory": n_memory,
        "memory": first.demo.metadata.get("memory"),
        "sources": list(SOURCES),
        "phases": phases,
        "files": files,
        "episodes": episodes,
    }
    text = json.dumps(carried, allow_nan=False, sort_keys=True, separators=(",", ":"))

    from ... import __version__

    root.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=".lfd-track-staging-", dir=root))
    try:
        with minari_root(staging) as minari:
            env = _env(first, observations)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # Minari's warnings about unset optional fields
                dataset = minari.create_dataset_from_buffers(
                    dataset_id=dataset_id,
                    buffer=buffers,
                    env=env,
                    algorithm_name=_algorithm(first.demo),
                    author="lfd-track",
                    description=(
                        f"{sum(r.demo.n_cases for r in recordings)} cases of"
                        f" {len(recordings)} lfd-track demonstration(s) on the"
                        f" '{first.demo.metadata['track']}' track:"
                        f" {'camera-frame' if observations == 'frames' else 'road-value'}"
                        " observations,"
                        " commands as actions (0 forward, 1 left, 2 right)"
                    ),
                    requirements=[f"lfd-track>={__version__}", "gymnasium>=1.0"],
                    # Frames are stored as they were seen, not JPEG-encoded (Minari's default for
                    # image observations, which is lossy).
                    jpeg_encoding=False,
                )
                dataset.storage.update_metadata({METADATA_KEY: text})
            env.close()
        with minari_root(root):
            from minari import namespace as namespaces

            if namespace is not None and namespace not in namespaces.list_local_namespaces():
                namespaces.create_namespace(namespace)
        built = staging / dataset_id
        target.parent.mkdir(parents=True, exist_ok=True)
        if target.exists():
            old = staging / ".replaced"
            os.replace(target, old)  # kept until the new dataset is in place
            try:
                os.replace(built, target)
            except BaseException:
                os.replace(old, target)
                raise
        else:
            os.replace(built, target)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    return target


def _algorithm(demo: Demonstration) -> str:
    meta = demo.metadata
    for key in ("method", "source"):
        if isinstance(meta.get(key), str):
            return f"lfd-track {meta[key]}"
    return "lfd-track demonstration"
