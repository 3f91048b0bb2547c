"""Demonstrations as Minari datasets of ``LfDTrack-v0``, and the cases a learner reads back.

One module per job: :mod:`.store` (the datasets folder, the ``minari`` import, dataset ids,
:func:`open_minari`), :mod:`.export` (recordings to a dataset) and :mod:`.cases` (a dataset back
to cases).

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

from .cases import MinariCases, cases_from_minari
from .export import export_minari
from .store import ENV_ID, METADATA_KEY, OBSERVATIONS, datasets_root, open_minari

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
