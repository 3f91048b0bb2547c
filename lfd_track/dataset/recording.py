"""Recording a session safely: the one way ``demo``, ``teach`` and ``hardware demo`` record.

A recording goes through a :class:`~lfd_track.teaching.perception.Perception`: its writer
(:func:`recording_writer`) logs the perception's road library as it learns (so a recording cut
short still trains) and carries the perception's memory inputs with every case, their settings
in the file's metadata. Where it is written is a :class:`RecordingTarget`:

- a new recording goes straight to its name: interrupted, it is still there, visible and usable;
- a recording that is to replace an existing file is written under an in-progress name of its
  own beside it (:func:`~lfd_track.utils.outputs.in_progress_name`) and moved over it only when
  finished (:meth:`RecordingTarget.commit`); interrupted, it is kept under a free partial name
  (:meth:`RecordingTarget.keep`), never over an earlier partial recording; failed, it is removed
  (:meth:`RecordingTarget.discard`). The earlier file is untouched until the new one replaces it.

:class:`ReplacingWriter` is the writer of a session that ends when it is closed (``teach``): it
replaces the earlier file on close only if the new recording holds a case.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..errors import LfdTrackError
from ..utils.atomic import replace_file
from ..utils.outputs import in_progress_name, keep_partial, shown_path
from .writer import DemonstrationWriter

if TYPE_CHECKING:
    from ..teaching.perception import Perception


def recording_writer(
    path: str | Path,
    metadata: dict[str, Any],
    perception: Perception,
    *,
    fsync: bool = True,
    overwrite: bool = False,
    log_library: bool = True,
) -> DemonstrationWriter:
    """A writer for a recording through ``perception``: it logs the perception's road library
    (unless ``log_library`` is False), adds its memory settings (if any) to ``metadata`` and
    carries its memory inputs per case."""
    memory = perception.memory_config
    if memory.kind != "none":
        metadata = {**metadata, "memory": memory.to_dict()}
    return DemonstrationWriter(
        path,
        metadata,
        bins=perception.library.bins,
        fsync=fsync,
        overwrite=overwrite,
        library=perception.library if log_library else None,
        n_memory=memory.n_inputs,
    )


class RecordingTarget:
    """Where a recording meant for ``out`` is written (see the module docstring).

    ``replace``: ``out`` exists and is to be replaced by the new recording, which is then
    written under an in-progress name (:attr:`path`) until :meth:`commit`.
    """

    def __init__(self, out: str | Path, *, replace: bool = False) -> None:
        self.out = Path(out)
        self.replacing = bool(replace)
        self.path = in_progress_name(self.out) if self.replacing else self.out

    def writer(
        self,
        metadata: dict[str, Any],
        perception: Perception,
        *,
        fsync: bool = True,
        overwrite: bool = False,
    ) -> DemonstrationWriter:
        """The :func:`recording_writer` of :attr:`path` (``overwrite``: an existing regular file
        at ``out`` may be emptied; a replacement's own name is always new)."""
        return recording_writer(
            self.path,
            metadata,
            perception,
            fsync=fsync,
            overwrite=overwrite and not self.replacing,
        )

    def commit(self, noun: str = "the new recording") -> Path:
        """Move a finished replacement over ``out``; returns ``out``. If ``out`` became something
        an output may not replace (a link, a device …), the recording is kept under a partial
        name and ``LfdTrackError`` says where (``noun``: how the message names it)."""
        if self.replacing:
            try:
                replace_file(self.path, self.out)
            except LfdTrackError as exc:
                kept = keep_partial(self.path, self.out)
                raise LfdTrackError(f"{exc}; {noun} is kept at {shown_path(kept)}") from None
        return self.out

    def keep(self) -> Path:
        """Where an interrupted recording is kept: ``out`` itself for a new recording, a free
        partial name beside ``out`` for a replacement (moved there now)."""
        return keep_partial(self.path, self.out) if self.replacing else self.out

    def discard(self) -> None:
        """Remove an unfinished replacement (the earlier ``out`` is untouched); a new recording
        is left where it is."""
        if self.replacing:
            self.path.unlink(missing_ok=True)


class ReplacingWriter:
    """The writer of a session recorded to ``target`` (a replacement) that ends with ``close``:
    a :class:`DemonstrationWriter`'s methods; closed with at least one case, the recording
    replaces ``target.out``; closed without a case it is deleted and ``out`` is left as it was,
    with a note on stderr (unless ``quiet``) saying so in the words of ``command``."""

    def __init__(self, writer: DemonstrationWriter, target: RecordingTarget, command: str) -> None:
        self._writer = writer
        self.target = target
        self.out = target.out
        self.command = command
        self.quiet = False
        self._done = False

    def __getattr__(self, name: str) -> Any:
        return getattr(self._writer, name)

    def close(self, final_metadata: dict[str, Any] | None = None) -> None:
        if self._done:
            return
        self._done = True
        try:
            self._writer.close(final_metadata)
        except BaseException:
            if self._writer.n_cases:  # the cases are kept, under a partial name beside ``out``
                self.target.keep()
            else:
                self.target.discard()
            raise
        if self._writer.n_cases:
            self.target.commit("the recording")
            return
        self.target.discard()
        if not self.quiet:
            print(
                f"lfd-track {self.command}: nothing was recorded; {shown_path(self.out)} is"
                " unchanged",
                file=sys.stderr,
                flush=True,
            )
