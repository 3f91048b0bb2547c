"""``lfd-track tracks``: draw a track (procedural loops too), write it as a track file that loads
back to the same vertices, list the tracks; user errors are one line and exit 1."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from lfd_track.cli import main
from lfd_track.world.track import load_track


@pytest.mark.parametrize(
    ("name", "flags"),
    [("random:test:17", []), ("random:validation:3", ["--reverse"]), ("testing", [])],
)
def test_show_writes_a_picture_and_a_track_file_that_loads_back(
    tmp_path, capsys, name: str, flags: list[str]
) -> None:
    png, toml = tmp_path / "loop.png", tmp_path / "loop.toml"
    assert main(["tracks", "show", name, "--out", str(png), "--toml", str(toml), *flags]) == 0
    picture = cv2.imread(str(png))
    assert picture is not None and picture.ndim == 3 and picture.shape[1] == 800
    shown = load_track(name, reverse="--reverse" in flags)
    written = load_track(toml)
    assert written.name == shown.name
    assert written.width_m == shown.width_m
    np.testing.assert_array_equal(written.vertices, shown.vertices)
    assert [(c.label, c.vertex) for c in written.corners] == [
        (c.label, c.vertex) for c in shown.corners
    ]
    out = capsys.readouterr().out
    assert out.startswith(f"{name}: loop") and "wrote" in out


def test_show_without_toml_and_with_a_start_corner(tmp_path) -> None:
    png = tmp_path / "t.png"
    assert main(["tracks", "show", "random:train:0", "--start-corner", "3", "--out", str(png)]) == 0
    assert png.is_file() and not (tmp_path / "t.toml").exists()


def test_list_names_the_shipped_tracks_and_the_loop_rule(capsys) -> None:
    assert main(["tracks", "list"]) == 0
    out = capsys.readouterr().out
    assert "testing: loop" in out and "training: open" in out
    assert "random:<split>:<index>" in out and "seed k*1000000 + i" in out


@pytest.mark.parametrize(
    ("args", "fragment"),
    [
        (["random:exam:1"], "unknown split 'exam'"),
        (["random"], "draws a new loop every episode"),
        (["random:test:x"], "whole number"),
        (["nowhere"], "unknown track 'nowhere'"),
        (["random:test:1", "--start-corner", "Z"], "no such corner"),
    ],
)
def test_bad_tracks_are_one_line_and_exit_1(tmp_path, capsys, args, fragment) -> None:
    png = tmp_path / "x.png"
    assert main(["tracks", "show", *args, "--out", str(png)]) == 1
    err = capsys.readouterr().err
    assert err.startswith("lfd-track tracks: ") and fragment in err
    assert err.count("\n") == 1
    assert not png.exists()


def test_the_same_file_for_both_outputs_is_refused(tmp_path, capsys) -> None:
    out = tmp_path / "x.png"
    assert main(["tracks", "show", "testing", "--out", str(out), "--toml", str(out)]) == 1
    assert "given as both --out and --toml" in capsys.readouterr().err
    assert not out.exists()


STUDY = """
[study]
name = "loops"
description = "a study scoring one procedural loop"
seeds = [0]
repetitions = 1

[[conditions]]
name = "paper"
method = "paper"
preset = "paper"
test_tracks = ["testing", "random:test:3"]
"""


def test_study_files_and_the_benchmark_checks_take_loop_names(tmp_path) -> None:
    from lfd_track.benchmark.runner import check_test_tracks, trial_directions
    from lfd_track.errors import FileFormatError
    from lfd_track.study.spec import load_study

    path = tmp_path / "loops.toml"
    path.write_text(STUDY, encoding="utf-8")
    (condition,) = load_study(path).conditions  # checks names and tracks as `study` does
    assert condition.config.test_tracks == ("testing", "random:test:3")
    check_test_tracks(("random:validation:0",))
    assert ("random:test:3", True, "cw") in trial_directions(("random:test:3",))
    path.write_text(STUDY.replace("random:test:3", "random:test"), encoding="utf-8")
    with pytest.raises(FileFormatError, match="draws a new loop every episode"):
        load_study(path)
