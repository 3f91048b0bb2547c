"""Demonstrations as Minari datasets of ``LfDTrack-v0``, and the cases a learner reads back.

:func:`export_minari` writes ``.lfdemo`` recordings as one Minari dataset
(``minari.create_dataset_from_buffers``, HDF5 storage); :func:`cases_from_minari` reads such a
dataset back into the cases the learners (GA, BC, CMA-ES) train on, with the road library a
controller drives with. Needs the ``minari`` extra.

What a dataset holds:

- **Observations**: the record-time road values, (40,) float64, exactly as the recording stores
  them (``Box(-1, 1, (40,), float64)``; a correlation may lie past +-1 by a rounding error, as in
  the recording); or, with ``observations="frames"``, the camera frames, (480, 640, 3) uint8,
  stored losslessly (not JPEG-encoded; about 0.9 MB a case).
  A recording stores no frames and a frame cannot be re-rendered from its pose alone (the
  camera's exposure, white balance and noise follow the random draws of the whole drive), so
  frames are exported only from a scripted demonstration (``lfd-track demo``,
  :func:`~lfd_track.demo.demonstrator.run_demonstration`): its drive is replayed from the
  recorded seed, and it is exported only if the replay gives the recording's commands, steps and
  road values (within 1e-9); otherwise one line says so. A frames dataset carries the recorded
  road values in the info ``road_values``, so learning from it reads the recording's cases.
- **Actions**: the commands, ``Discrete(3)`` (0 forward, 1 left, 2 right).
- **Episodes**: each run of consecutive recorded steps of one round of a file is an episode
  (a demonstration protocol drive is one; the rounds of corrections are more). A recording does
  not store the frame after its last command, so an episode's final observation repeats its
  last recorded one; its info ``case`` is -1. The recording ended the episode, so its last step
  is *truncated*; nothing is terminated. Rewards are not recorded: they are 0.
- **Infos** (one per observation, the same keys in every dataset): ``case`` (the case's index
  in its file, -1 for the final observation), ``step``, ``pose`` (3,), ``progress_m``,
  ``learned``, ``phase`` (index into the metadata's ``phases``; -1 for the final observation),
  ``source`` (index into :data:`~lfd_track.dataset.records.SOURCES`), ``round``,
  ``histograms`` (40, 5, bins) float32 (the region histograms the values came from) and
  ``memory`` (m,) float64 (the policy's memory inputs; m = 0 without memory). The final
  observation has NaN pose and progress and zero histograms and memory.
- **Metadata** under the key :data:`METADATA_KEY` (a JSON string): every file's name,
  metadata and road library, which file and first case each episode comes from, the memory
  settings, the bins, and the names of the phases and sources the infos index.
- **Environment**: the spec of ``LfDTrack-v0`` on the recordings' track and preset, wrapped in
  :class:`~lfd_track.envs.library_observation.LibraryRoadValueObservation` with the first
  file's road library, so ``recover_environment()`` gives an env whose observations are road
  values as the controller learned from the dataset sees them; ``requirements`` name lfd-track
  and Gymnasium.

Learning back: the controller drives with the first file's road library. Cases of an episode
whose file was recorded with another library have their road values recomputed from their region
histograms with that library (what the histograms are stored for); episodes of the first file,
or of files with the same library, keep the recorded values, so one exported file gives exactly
the cases the file gives.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import shutil
import tempfile
import warnings
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import LfdTrackError, first_line
from ..policy.memory import MemoryConfig
from ..utils.extras import needs_extra
from ..utils.outputs import shown_path
from ..vision.road_library import RoadLibrary
from .checks import _memory_problem, _road_value_problem
from .model import Demonstration
from .reader import load_demonstration, load_for_learning
from .records import N_CHANNELS, N_VALUES, SOURCES

__all__ = [
    "ENV_ID",
    "METADATA_KEY",
    "OBSERVATIONS",
    "MinariCases",
    "cases_from_minari",
    "datasets_root",
    "export_minari",
    "open_minari",
]

ENV_ID = "LfDTrack-v0"
"""The environment every exported dataset is a dataset of."""
OBSERVATIONS = ("road-values", "frames")
"""What an exported dataset's observations may be (only road values can be exported)."""
METADATA_KEY = "lfd_track"
"""The dataset metadata key holding what learning needs (a JSON string)."""
_FORMAT = "lfd-track demonstrations"
_FORMAT_VERSION = 1
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
    from ..core.config import config_from_dict
    from ..demo.demonstrator import HumanConfig, run_demonstration
    from ..vision.road_library import RoadLibrary

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


def datasets_root(datasets_path: str | Path | None = None) -> Path:
    """The folder holding Minari datasets: ``datasets_path``, else Minari's own
    (``MINARI_DATASETS_PATH``, else ``~/.minari/datasets``)."""
    if datasets_path is not None:
        return Path(datasets_path)
    env = os.environ.get("MINARI_DATASETS_PATH")
    if env is not None:
        return Path(env)
    return Path.home() / ".minari" / "datasets"


def _import_minari() -> Any:
    """The ``minari`` module; a missing part of the extra is one line naming it."""
    with needs_extra("minari"):
        # Minari's HDF5 storage needs h5py and Pillow; imported here for a clear line.
        import h5py  # noqa: F401
        import minari
        import PIL  # noqa: F401
    return minari


@contextlib.contextmanager
def _minari_root(root: Path) -> Iterator[Any]:
    """The ``minari`` module with its datasets folder set to ``root`` for the block.

    Minari finds its datasets through ``MINARI_DATASETS_PATH`` only; it is set for the block and
    restored after it.
    """
    minari = _import_minari()
    before = os.environ.get("MINARI_DATASETS_PATH")
    os.environ["MINARI_DATASETS_PATH"] = str(root.absolute())  # minari mis-joins relative paths
    try:
        yield minari
    finally:
        if before is None:
            os.environ.pop("MINARI_DATASETS_PATH", None)
        else:
            os.environ["MINARI_DATASETS_PATH"] = before


def _check_dataset_id(dataset_id: str) -> str | None:
    """The namespace of a valid ``[NAMESPACE/]NAME-vVERSION`` id (LfdTrackError otherwise)."""
    _import_minari()
    from minari.dataset.minari_dataset import parse_dataset_id

    if not re.search(r"-v\d+$", dataset_id):
        raise LfdTrackError(
            f"dataset id '{dataset_id}' has no version (e.g. lfd-track/training-v0)"
        )
    try:
        namespace, _, _ = parse_dataset_id(dataset_id)
    except (ValueError, TypeError):
        raise LfdTrackError(
            f"dataset id '{dataset_id}' is not of the form [NAMESPACE/]NAME-vVERSION"
            " (e.g. lfd-track/training-v0)"
        ) from None
    return namespace


# ------------------------------------------------------------------------------------- export
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

    from ..envs.library_observation import LibraryRoadValueObservation
    from ..envs.registration import register_envs

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
    namespace = _check_dataset_id(dataset_id)
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
    buffers = []
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
    carried = {
        "format": _FORMAT,
        "version": _FORMAT_VERSION,
        "observations": observations,
        "bins": first.demo.bins,
        "n_memory": int(first.demo.memory.shape[1]),
        "memory": first.demo.metadata.get("memory"),
        "sources": list(SOURCES),
        "phases": phases,
        "files": files,
        "episodes": episodes,
    }
    text = json.dumps(carried, allow_nan=False, sort_keys=True, separators=(",", ":"))

    from .. import __version__

    root.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=".lfd-track-staging-", dir=root))
    try:
        with _minari_root(staging) as minari:
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
        with _minari_root(root):
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


# -------------------------------------------------------------------------------- learning back
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
    if not isinstance(carried, dict) or carried.get("format") != _FORMAT:
        raise LfdTrackError(f"Minari dataset {dataset_id}: unknown '{METADATA_KEY}' metadata")
    if carried.get("version") != _FORMAT_VERSION:
        raise LfdTrackError(
            f"Minari dataset {dataset_id}: written by another lfd-track (format version"
            f" {carried.get('version')!r}, this one reads {_FORMAT_VERSION})"
        )
    return carried


def open_minari(dataset_id: str, *, datasets_path: str | Path | None = None) -> Any:
    """The ``minari.MinariDataset`` ``dataset_id`` in ``datasets_path`` (None: Minari's own
    folder), e.g. to ``recover_environment()`` or iterate its episodes.

    Raises LfdTrackError (one line) when there is no such dataset or it cannot be read.
    """
    _check_dataset_id(dataset_id)
    root = datasets_root(datasets_path)
    if not (root / dataset_id).is_dir():
        raise LfdTrackError(f"no Minari dataset {dataset_id} in {shown_path(root)}")
    with _minari_root(root) as minari:
        try:
            return minari.load_dataset(dataset_id)
        except (ValueError, OSError, KeyError, TypeError) as exc:
            raise LfdTrackError(
                f"Minari dataset {dataset_id}: cannot be read ({first_line(exc)})"
            ) from None


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
