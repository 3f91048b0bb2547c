"""Writing ``.lfdemo`` files: case by case and crash-safe (:class:`DemonstrationWriter`), or a
whole loaded demonstration at once, atomically (:func:`save_demonstration`).

Each case is one ``write`` of one record on an unbuffered file (and by default ``fsync``-ed), so
a killed recorder loses at most the case being written (see :mod:`lfd_track.dataset.records`).
"""

from __future__ import annotations

import os
import stat
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import FileFormatError
from ..utils.atomic import atomic_write_bytes
from ..utils.outputs import refuse_unsafe_output
from ..vision.road_library import LibraryChange, LibraryLearned, RoadLibrary
from .checks import _check_bins, _check_n_memory
from .model import _DERIVED_KEYS, Demonstration, _counts
from .records import (
    _MAGIC,
    DEFAULT_BINS,
    _case_record,
    _footer_record,
    _header_record,
    _learned_record,
    _selected_record,
)


def _open_recording(path: Path, overwrite: bool) -> Any:
    """``path`` opened for writing, unbuffered: a new file, or with ``overwrite`` an existing
    regular file emptied. Nothing but a regular file is opened (not through a symbolic link, nor
    a FIFO or a device that appeared since :func:`refuse_unsafe_output` looked)."""
    if not overwrite:
        return open(path, "xb", buffering=0)  # noqa: SIM115 - exclusive: never an existing file
    flags = os.O_WRONLY | os.O_CREAT | getattr(os, "O_CLOEXEC", 0)
    flags |= getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0)
    fd = os.open(path, flags, 0o666)
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            refuse_unsafe_output(path)
            raise FileFormatError(path, "not a regular file; an output only replaces one")
        os.set_blocking(fd, True)
        os.ftruncate(fd, 0)
    except BaseException:
        os.close(fd)
        raise
    return open(fd, "wb", buffering=0)  # noqa: SIM115


class DemonstrationWriter:
    """Record a demonstration case by case into a crash-safe ``.lfdemo`` log.

    Use as a context manager. Leaving the ``with`` block normally writes the footer; leaving it
    through an exception closes the file without one, so it loads as ``complete = False`` with
    every case appended so far.

    Args:
        path: file to create.
        metadata: JSON-friendly file metadata (track name, seed, demonstrator config, ...).
        bins: histogram bins per channel.
        fsync: ``fsync`` after every case, so cases also survive a power cut (a killed process
            loses nothing already appended either way, because writes are unbuffered).
        overwrite: replace an existing file instead of refusing.
        library: road library to log: its state now goes in the header and every later change
            (learning step, counter update) is appended as it happens, until the writer closes.
            Its ``bins`` must equal ``bins``.
        n_memory: memory inputs every case carries (0: none, a schema 2 file).
    """

    def __init__(
        self,
        path: str | Path,
        metadata: Mapping[str, Any],
        bins: int = DEFAULT_BINS,
        *,
        fsync: bool = True,
        overwrite: bool = False,
        library: RoadLibrary | None = None,
        n_memory: int = 0,
    ) -> None:
        self.path = Path(path)
        self.bins = _check_bins(bins)
        self.n_memory = _check_n_memory(n_memory)
        self._fsync = fsync
        self._commands: list[int] = []
        self._records = 0  # records written after the header (each carries its index)
        self._unsubscribe: Any = None
        if library is not None and library.bins != self.bins:
            raise ValueError(f"library has {library.bins} bins, the file {self.bins}")
        initial = None if library is None else library.to_dict()
        header = _header_record(metadata, self.bins, initial, self.n_memory)
        refuse_unsafe_output(self.path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        # Unbuffered: each record reaches the kernel in one write() call, so SIGKILL cannot
        # leave a record half in a user-space buffer.
        self._file = _open_recording(self.path, overwrite)
        try:
            self._write(_MAGIC + header)
            self._sync_directory()
        except BaseException:
            # Nothing was recorded (a full disk, an interrupt): leave no file that a later run
            # would have to be told to --force over.
            self._file.close()
            self.path.unlink(missing_ok=True)
            raise
        if library is not None:
            self._unsubscribe = library.subscribe(self._on_library_change)

    def _on_library_change(self, change: LibraryChange) -> None:
        if self._file.closed:
            return
        if isinstance(change, LibraryLearned):
            record = _learned_record(change, self._records + 1)
        else:
            record = _selected_record(change.per_model, self._records + 1)
        # No fsync of its own: the next case's fsync makes it durable (unbuffered writes already
        # survive a killed process).
        self._write_record(record, sync=False)

    @property
    def n_cases(self) -> int:
        """Cases appended so far."""
        return len(self._commands)

    @property
    def closed(self) -> bool:
        """True once ``close`` ran (or the file was abandoned after an error)."""
        return self._file.closed

    def append(
        self,
        command: int,
        road_values: np.ndarray,
        region_histograms: np.ndarray,
        *,
        pose: tuple[float, float, float] | np.ndarray | None = None,
        progress_m: float | None = None,
        phase: str = "drive",
        learned: bool = False,
        step: int | None = None,
        source: str = "demonstration",
        round: int = 0,  # the file's field name (shadows the builtin only in here)
        memory: np.ndarray | None = None,
    ) -> None:
        """Append one case and make it durable before returning.

        Args:
            command: 0 forward, 1 left, 2 right.
            road_values: (40,) float — values in [-1, 1], stored as float64.
            region_histograms: (40, 5, bins) float — stored as float32.
            pose: (x [m], y [m], theta [rad]) if known, else None (stored as NaN).
            progress_m: progress along the centreline [m], None if unknown (stored as NaN).
            phase: phase label, e.g. "library_only", "drive", "turnaround".
            learned: whether the road library learned from this frame.
            step: recorder step index (>= 0); defaults to the number of cases appended before.
            source: ``"demonstration"`` or ``"correction"`` (a human command that took control
                back from the policy, or an intervention during an autonomous run).
            round: 0 for the initial demonstration, r for the r-th round of autonomous runs.
            memory: the policy's memory inputs, (n_memory,) in [0, 1] (None when the file has
                none).
        """
        if self._file.closed:
            raise ValueError(f"{self.path}: demonstration writer is closed")
        index = len(self._commands) if step is None else int(step)
        record = _case_record(
            self.bins,
            index,
            command,
            road_values,
            region_histograms,
            pose,
            progress_m,
            phase,
            learned,
            source,
            round,
            memory,
            self.n_memory,
            self._records + 1,
        )
        self._write_record(record)
        self._commands.append(int(command))

    def close(self, final_metadata: Mapping[str, Any] | None = None) -> None:
        """Write the footer (final metadata, e.g. the road library snapshot, plus counts)."""
        if self._file.closed:
            return
        self._stop_logging()
        try:
            footer = _footer_record(
                final_metadata or {}, _counts(self._commands), self.n_cases, self._records + 1
            )
            self._write_record(footer)
        finally:
            self._file.close()

    def abandon(self) -> None:
        """Close without a footer: the file will load as an interrupted recording."""
        self._stop_logging()
        if not self._file.closed:
            self._file.close()

    def _stop_logging(self) -> None:
        if self._unsubscribe is not None:
            self._unsubscribe()
            self._unsubscribe = None

    def _write_record(self, record: bytes, *, sync: bool = True) -> None:
        """Write a record after the header (numbered ``self._records + 1``)."""
        self._write(record, sync=sync)
        self._records += 1

    def _write(self, data: bytes, *, sync: bool = True) -> None:
        view = memoryview(data)
        while view:  # a raw write may be partial (signals, pipes); finish the record
            written = self._file.write(view)
            view = view[written:]
        if self._fsync and sync:
            os.fsync(self._file.fileno())

    def _sync_directory(self) -> None:
        # Make the new directory entry durable too, or a power cut could lose the whole file.
        if not self._fsync or os.name != "posix":
            return
        fd = os.open(self.path.parent, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)

    def __enter__(self) -> DemonstrationWriter:
        return self

    def __exit__(self, exc_type: object, exc: object, tb: object) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abandon()


def save_demonstration(path: str | Path, demonstration: Demonstration) -> None:
    """Write ``demonstration`` as a complete ``.lfdemo`` file atomically (convert or copy)."""
    demo = demonstration
    bins = _check_bins(demo.bins)
    # Everything goes in the header; the loader merges header and footer, so the view is the same.
    meta = {k: v for k, v in demo.metadata.items() if k not in _DERIVED_KEYS}
    assert demo.memory is not None
    n_memory = _check_n_memory(demo.memory.shape[1])
    parts = [_MAGIC, _header_record(meta, bins, n_memory=n_memory)]
    for i in range(demo.n_cases):
        parts.append(
            _case_record(
                bins,
                int(demo.steps[i]),
                int(demo.commands[i]),
                demo.road_values[i],
                demo.histograms[i],
                demo.poses[i],
                float(demo.progress_m[i]),
                str(demo.phases[i]),
                bool(demo.learned[i]),
                str(demo.sources[i]),
                int(demo.rounds[i]),
                demo.memory[i],
                n_memory,
                i + 1,
            )
        )
    parts.append(_footer_record({}, _counts(demo.commands), demo.n_cases, demo.n_cases + 1))
    atomic_write_bytes(path, b"".join(parts))
