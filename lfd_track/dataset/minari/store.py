"""Where Minari datasets live and how lfd-track opens them: the dataset folder, the ``minari``
import (the extra), dataset ids, and the metadata entry that marks an lfd-track dataset.

The dataset format is described in :mod:`lfd_track.dataset.minari`.
"""

from __future__ import annotations

import contextlib
import os
import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from ...errors import LfdTrackError, first_line
from ...utils.extras import needs_extra
from ...utils.outputs import shown_path

ENV_ID = "LfDTrack-v0"
"""The environment every exported dataset is a dataset of."""
OBSERVATIONS = ("road-values", "frames")
"""What an exported dataset's observations may be (frames only from a scripted demonstration)."""
METADATA_KEY = "lfd_track"
"""The dataset metadata key holding what learning needs (a JSON string)."""
FORMAT = "lfd-track demonstrations"
"""The ``format`` entry of the metadata under :data:`METADATA_KEY`."""
FORMAT_VERSION = 1
"""The ``version`` entry of that metadata: the layout this lfd-track writes and reads."""


def datasets_root(datasets_path: str | Path | None = None) -> Path:
    """The folder holding Minari datasets: ``datasets_path``, else Minari's own
    (``MINARI_DATASETS_PATH``, else ``~/.minari/datasets``)."""
    if datasets_path is not None:
        return Path(datasets_path)
    env = os.environ.get("MINARI_DATASETS_PATH")
    if env is not None:
        return Path(env)
    return Path.home() / ".minari" / "datasets"


def import_minari() -> Any:
    """The ``minari`` module; a missing part of the extra is one line naming it."""
    with needs_extra("minari"):
        # Minari's HDF5 storage needs h5py and Pillow; imported here for a clear line.
        import h5py  # noqa: F401
        import minari
        import PIL  # noqa: F401
    return minari


@contextlib.contextmanager
def minari_root(root: Path) -> Iterator[Any]:
    """The ``minari`` module with its datasets folder set to ``root`` for the block.

    Minari finds its datasets through ``MINARI_DATASETS_PATH`` only; it is set for the block and
    restored after it.
    """
    minari = import_minari()
    before = os.environ.get("MINARI_DATASETS_PATH")
    os.environ["MINARI_DATASETS_PATH"] = str(root.absolute())  # minari mis-joins relative paths
    try:
        yield minari
    finally:
        if before is None:
            os.environ.pop("MINARI_DATASETS_PATH", None)
        else:
            os.environ["MINARI_DATASETS_PATH"] = before


def check_dataset_id(dataset_id: str) -> str | None:
    """The namespace of a valid ``[NAMESPACE/]NAME-vVERSION`` id (LfdTrackError otherwise)."""
    import_minari()
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


def open_minari(dataset_id: str, *, datasets_path: str | Path | None = None) -> Any:
    """The ``minari.MinariDataset`` ``dataset_id`` in ``datasets_path`` (None: Minari's own
    folder), e.g. to ``recover_environment()`` or iterate its episodes.

    Raises LfdTrackError (one line) when there is no such dataset or it cannot be read.
    """
    check_dataset_id(dataset_id)
    root = datasets_root(datasets_path)
    if not (root / dataset_id).is_dir():
        raise LfdTrackError(f"no Minari dataset {dataset_id} in {shown_path(root)}")
    with minari_root(root) as minari:
        try:
            return minari.load_dataset(dataset_id)
        except (ValueError, OSError, KeyError, TypeError) as exc:
            raise LfdTrackError(
                f"Minari dataset {dataset_id}: cannot be read ({first_line(exc)})"
            ) from None
