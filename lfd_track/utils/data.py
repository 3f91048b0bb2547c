"""Locate the data folders (`tracks/`, `envs/`) shipped with the package.

In a wheel they live in ``lfd_track/_data/<name>``; in a source checkout (editable install or
running from the repository) they are the top-level folders of the repository.
"""

from __future__ import annotations

from pathlib import Path

from ..errors import LfdTrackError

_PACKAGE_DIR = Path(__file__).resolve().parent.parent  # lfd_track/


def data_dir(name: str) -> Path:
    """Return the folder holding the shipped data files of kind ``name`` ("tracks" or "envs")."""
    for candidate in (_PACKAGE_DIR / "_data" / name, _PACKAGE_DIR.parent / name):
        if candidate.is_dir():
            return candidate
    raise FileNotFoundError(f"lfd_track data folder '{name}' not found next to {_PACKAGE_DIR}")


_WHAT = {"tracks": "track", "envs": "preset"}


class UnknownDataError(LfdTrackError, FileNotFoundError):
    """A track or preset name that is not shipped, or a path that does not exist."""


def resolve_data_file(kind: str, name_or_path: str | Path) -> Path:
    """Resolve a shipped data file by short name (``"testing"``) or a path to a ``.toml`` file."""
    what = _WHAT.get(kind, kind)
    text = str(name_or_path)
    path = Path(text)
    try:
        exists = path.exists()
        as_path = exists and not path.is_dir()  # a file, FIFO or device given by name
    except OSError as exc:  # e.g. a name longer than the file system allows
        raise UnknownDataError(f"{path}: cannot use as a {what} file ({exc.strerror})") from None
    if path.suffix == ".toml" or as_path or "/" in text or "\\" in text:
        if not exists:
            raise UnknownDataError(f"{path}: no such {what} file")
        return path  # the reader refuses folders, FIFOs and devices naming the file
    shipped = data_dir(kind) / f"{text}.toml"
    try:
        is_shipped = shipped.is_file()
    except OSError as exc:
        raise UnknownDataError(f"unknown {what} '{text}' ({exc.strerror})") from None
    if not is_shipped:
        known = sorted(p.stem for p in data_dir(kind).glob("*.toml"))
        raise UnknownDataError(
            f"unknown {what} '{text}' (shipped: {', '.join(known)}; or a path to a .toml file)"
        )
    return shipped
