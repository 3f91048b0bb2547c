"""Atomic writes: complete files only, ordinary permissions, clear refusal of a folder."""

from __future__ import annotations

import os
import stat

import pytest

from lfd_track.utils.atomic import atomic_write_bytes, atomic_write_text


def test_write_replaces_the_file_whole_with_ordinary_permissions(tmp_path):
    path = tmp_path / "sub" / "out.json"
    atomic_write_text(path, "old")
    atomic_write_text(path, "new")
    assert path.read_text() == "new"
    mask = os.umask(0)
    os.umask(mask)
    assert stat.S_IMODE(path.stat().st_mode) == 0o666 & ~mask
    assert sorted(p.name for p in path.parent.iterdir()) == ["out.json"]


def test_a_folder_is_refused_and_nothing_is_left_behind(tmp_path):
    folder = tmp_path / "results"
    folder.mkdir()
    with pytest.raises(IsADirectoryError, match="is a folder"):
        atomic_write_bytes(folder, b"x")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["results"]


def test_a_failed_write_keeps_the_old_file(tmp_path, monkeypatch):
    path = tmp_path / "keep.txt"
    atomic_write_text(path, "precious")

    def broken_replace(src, dst):
        raise OSError("disk full")

    monkeypatch.setattr(os, "replace", broken_replace)
    with pytest.raises(OSError, match="disk full"):
        atomic_write_text(path, "half")
    assert path.read_text() == "precious"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["keep.txt"]


def test_the_longest_file_names_are_written(tmp_path):
    """The temporary name beside the file must not be longer than the file system allows."""
    for name in ("x" * 250 + ".json", "é" * 125 + ".png"):  # 255 bytes each
        path = tmp_path / name
        atomic_write_text(path, "data")
        assert path.read_text() == "data"
    assert len(list(tmp_path.iterdir())) == 2


@pytest.mark.parametrize("kind", ["fifo", "link"])
def test_a_fifo_or_a_symbolic_link_is_never_replaced(tmp_path, kind):
    from lfd_track.errors import LfdTrackError

    path = tmp_path / "out.json"
    target = tmp_path / "elsewhere.json"
    target.write_text("kept")
    if kind == "fifo":
        os.mkfifo(path)
    else:
        path.symlink_to(target)
    with pytest.raises(LfdTrackError, match="a FIFO|symbolic link") as info:
        atomic_write_text(path, "new")
    assert str(path) in str(info.value)
    mode = os.lstat(path).st_mode
    assert stat.S_ISFIFO(mode) if kind == "fifo" else stat.S_ISLNK(mode)
    assert target.read_text() == "kept"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["elsewhere.json", "out.json"]
