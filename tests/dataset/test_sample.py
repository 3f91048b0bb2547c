"""The shipped sample demonstrations (lfd_track/dataset/sample.py, lfd-track sample-data)."""

from __future__ import annotations

import zipfile

import pytest

from lfd_track.cli import main
from lfd_track.dataset import load_demonstration
from lfd_track.dataset.sample import sample_archive, write_sample_data
from lfd_track.errors import FileFormatError, LfdTrackError

NAMES = ["training-0.lfdemo", "training-1.lfdemo", "training-2.lfdemo"]


def test_sample_data_writes_three_demonstrations_to_learn_from(tmp_path, capsys):
    assert main(["sample-data", str(tmp_path / "sample")]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 3 and lines[0].endswith("38 cases (24 forward, 9 left, 5 right)")
    assert sorted(p.name for p in (tmp_path / "sample").iterdir()) == NAMES
    for name in NAMES:
        demo = load_demonstration(tmp_path / "sample" / name)
        assert demo.metadata["complete"] and demo.metadata["track"] == "training"
        assert demo.road_library().n_models > 0 and demo.bins == 8
        assert set(demo.command_counts.values()) != {0}
    assert sample_archive().stat().st_size < 400_000


def test_existing_files_are_kept_without_force(tmp_path, capsys):
    (tmp_path / NAMES[1]).write_bytes(b"mine")
    assert main(["sample-data", str(tmp_path)]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and NAMES[1] in err and "--force" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == [NAMES[1]]
    assert (tmp_path / NAMES[1]).read_bytes() == b"mine"
    assert main(["sample-data", str(tmp_path), "--force"]) == 0
    assert load_demonstration(tmp_path / NAMES[1]).n_cases == 35


def test_a_damaged_archive_member_is_refused_before_it_takes_a_name(tmp_path):
    archive = tmp_path / "damaged.zip"
    with zipfile.ZipFile(sample_archive()) as good, zipfile.ZipFile(archive, "w") as bad:
        for info in good.infolist():
            data = good.read(info)
            if info.filename == NAMES[1]:
                data = data[: len(data) // 2] + b"\xff" * 64 + data[len(data) // 2 + 64 :]
            bad.writestr(info.filename, data)
    out = tmp_path / "out"
    with pytest.raises(FileFormatError, match=f"damaged.zip:{NAMES[1]}: ") as caught:
        write_sample_data(out, archive=archive)
    assert "\n" not in str(caught.value)
    assert sorted(p.name for p in out.iterdir()) == [NAMES[0]]  # nothing half-written


@pytest.mark.parametrize("member", ["../escape.lfdemo", "sub/dir.lfdemo", "notes.txt"])
def test_an_archive_member_with_a_bad_name_is_refused(tmp_path, member):
    archive = tmp_path / "odd.zip"
    with zipfile.ZipFile(archive, "w") as z:
        z.writestr(member, b"x")
    with pytest.raises(FileFormatError, match="is not a plain .lfdemo name"):
        write_sample_data(tmp_path / "out", archive=archive)
    assert not (tmp_path / "escape.lfdemo").exists()


def test_a_file_where_the_folder_should_be_is_one_line(tmp_path):
    (tmp_path / "f").write_text("x")
    with pytest.raises(LfdTrackError, match="is not a folder"):
        write_sample_data(tmp_path / "f")
