"""Locate the data folders (`tracks/`, `envs/`) shipped with the package.

In a wheel they live in ``lfd_track/_data/<name>``; in a source checkout (editable install or
running from the repository) they are the top-level folders of the repository.
"""

from __future__ import annotations

from pathlib import Path

_PACKAGE_DIR = Path(__file__).resolve().parent


def data_dir(name: str) -> Path:
    """Return the folder holding the shipped data files of kind ``name`` ("tracks" or "envs")."""
    for candidate in (_PACKAGE_DIR / "_data" / name, _PACKAGE_DIR.parent / name):
        if candidate.is_dir():
            return candidate
    raise FileNotFoundError(f"lfd_track data folder '{name}' not found next to {_PACKAGE_DIR}")


def resolve_data_file(kind: str, name_or_path: str | Path) -> Path:
    """Resolve a shipped data file by short name (``"testing"``) or a path to a ``.toml`` file."""
    text = str(name_or_path)
    path = Path(text)
    if path.suffix == ".toml" or path.is_file() or "/" in text or "\\" in text:
        if not path.is_file():
            raise FileNotFoundError(f"{path}: no such {kind[:-1]} file")
        return path
    shipped = data_dir(kind) / f"{text}.toml"
    if not shipped.is_file():
        known = sorted(p.stem for p in data_dir(kind).glob("*.toml"))
        raise FileNotFoundError(
            f"unknown {kind[:-1]} '{text}' (shipped: {', '.join(known)}; or give a path to a .toml file)"
        )
    return shipped
