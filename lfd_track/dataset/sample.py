"""The sample demonstrations shipped with lfd-track: something to learn from without simulating.

``samples/demonstrations.zip`` (in a wheel ``lfd_track/_data/samples/``) holds three
``.lfdemo`` recordings of the scripted human driving the training track once from its right end
to its left end (seeds 0, 1 and 2; road libraries of 8 bins per channel, which keeps the archive
small; ``scripts/make_sample_data.py`` writes it). :func:`write_sample_data` unpacks them into a
folder; every one is read back with :func:`~lfd_track.dataset.reader.load_demonstration`, like
any user file, before it takes its name.
"""

from __future__ import annotations

import re
import zipfile
from pathlib import Path

from ..errors import FileFormatError, LfdTrackError
from ..utils.atomic import replace_file, temporary_beside
from ..utils.data import data_dir
from ..utils.outputs import shown_path, taken
from .model import Demonstration
from .reader import load_demonstration
from .records import FILE_EXTENSION

__all__ = ["SAMPLE_ARCHIVE", "sample_archive", "write_sample_data"]

SAMPLE_ARCHIVE = "demonstrations.zip"
"""The archive's name in the shipped ``samples`` folder."""
_MEMBER = re.compile(rf"[a-z0-9-]{{1,64}}{re.escape(FILE_EXTENSION)}")
_MAX_MEMBER_BYTES = 1 << 24  # [bytes] far more than a sample recording holds
_MAX_MEMBERS = 16


def sample_archive() -> Path:
    """The shipped archive of sample demonstrations."""
    return data_dir("samples", required=[SAMPLE_ARCHIVE]) / SAMPLE_ARCHIVE


def _members(archive: Path) -> list[zipfile.ZipInfo]:
    try:
        with zipfile.ZipFile(archive) as z:
            infos = z.infolist()
    except (zipfile.BadZipFile, OSError) as exc:
        raise FileFormatError(shown_path(archive), f"not a readable zip archive ({exc})") from None
    if not infos or len(infos) > _MAX_MEMBERS:
        raise FileFormatError(shown_path(archive), f"holds {len(infos)} files, expected 1-16")
    for info in infos:
        if not _MEMBER.fullmatch(info.filename):
            raise FileFormatError(
                shown_path(archive),
                f"member {info.filename!r} is not a plain {FILE_EXTENSION} name",
            )
        if info.file_size > _MAX_MEMBER_BYTES:
            raise FileFormatError(
                shown_path(archive), f"member {info.filename} is larger than a sample can be"
            )
    return infos


def write_sample_data(
    folder: str | Path, *, force: bool = False, archive: str | Path | None = None
) -> list[tuple[Path, Demonstration]]:
    """Unpack the sample demonstrations into ``folder`` (made if missing); return each file
    with its loaded demonstration.

    An existing file of the same name is replaced only with ``force`` (each file is checked
    before it replaces anything). ``archive`` None means the shipped one.

    Raises:
        LfdTrackError: a file exists (without ``force``), or a member is not a valid recording
            (:class:`FileFormatError` naming ``archive:member``).
    """
    source = Path(archive) if archive is not None else sample_archive()
    out = Path(folder)
    if out.exists() and not out.is_dir():
        raise LfdTrackError(f"{shown_path(out)}: exists and is not a folder")
    infos = _members(source)
    targets = [out / info.filename for info in infos]
    if not force:
        for target in targets:
            if taken(target):
                raise LfdTrackError(
                    f"{shown_path(target)}: already exists (use --force to replace it)"
                )
    written = []
    with zipfile.ZipFile(source) as z:
        for info, target in zip(infos, targets, strict=True):
            where = f"{shown_path(source)}:{info.filename}"
            try:
                data = z.read(info)
            except (zipfile.BadZipFile, OSError, EOFError) as exc:
                raise FileFormatError(where, f"cannot be unpacked ({exc})") from None
            staged = temporary_beside(target)
            try:
                staged.write_bytes(data)
                try:
                    demo = load_demonstration(staged)
                except FileFormatError as exc:
                    raise FileFormatError(where, exc.problem) from None
                replace_file(staged, target)
            except BaseException:
                staged.unlink(missing_ok=True)
                raise
            written.append((target, demo))
    return written
