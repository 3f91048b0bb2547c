"""Find the data shipped with the package: tracks, presets and the firmware/harness sources.

One lookup for all of them. In a wheel they live inside the package, in
``lfd_track/_data/<kind>`` (``pyproject.toml`` force-includes the checkout's ``tracks/``,
``envs/``, ``samples/`` and the firmware and harness sources under ``hardware/``), found with
:mod:`importlib.resources`; in a source checkout (editable install, or running from the
repository) they are the repository's top-level folders of the same name.
"""

from __future__ import annotations

from collections.abc import Iterable
from importlib import resources
from pathlib import Path

from ..errors import LfdTrackError

KINDS = ("tracks", "envs", "hardware", "samples")
"""The kinds of shipped data: track files, presets, firmware and harness sources, sample
demonstrations."""

_CHECKOUT = Path(__file__).resolve().parents[2]
"""The repository root when running from a checkout (the folder holding ``lfd_track/``)."""


def shipped_dir(kind: str) -> Path:
    """Where a wheel keeps data of ``kind``: ``lfd_track/_data/<kind>`` (it may not exist)."""
    if kind not in KINDS:
        raise ValueError(f"unknown kind of shipped data {kind!r} (known: {', '.join(KINDS)})")
    folder = resources.files("lfd_track").joinpath("_data", kind)
    if not isinstance(folder, Path):  # a zipped package: not how lfd-track is installed
        raise FileNotFoundError(f"lfd_track data folder '{kind}' is not on the file system")
    return folder


def data_dir(kind: str, *, required: Iterable[str] = ()) -> Path:
    """The folder holding the shipped data of ``kind`` (one of :data:`KINDS`).

    The wheel's copy first, then the checkout's top-level folder; with ``required`` (paths
    relative to the folder), the first that holds all of them.
    """
    needed = tuple(required)
    for candidate in (shipped_dir(kind), _CHECKOUT / kind):
        if candidate.is_dir() and all((candidate / name).is_file() for name in needed):
            return candidate
    raise FileNotFoundError(
        f"lfd_track data folder '{kind}' not found in {shipped_dir(kind)} or {_CHECKOUT / kind}"
    )


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
