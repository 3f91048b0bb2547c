"""A controller records the frame size it learned on; driving at another size says so once."""

from __future__ import annotations

import json

import numpy as np
import pytest
from lfd_test_support import REPO

from lfd_track.methods.common import MethodContext
from lfd_track.policy.controller import Controller
from lfd_track.policy.mlp import n_weights
from lfd_track.teaching import perception as perception_module
from lfd_track.vision.road_library import RoadLibrary

DATA = REPO / "tests" / "data"


def _controller(frame_size=(640, 480)) -> Controller:
    rng = np.random.default_rng(3)
    library = RoadLibrary()
    width, height = frame_size
    library.learn(rng.integers(0, 256, (height, width, 3), dtype=np.uint8))
    weights = rng.uniform(-1, 1, n_weights(False, 40))
    return Controller(library, weights, frame_size=frame_size)


def test_the_frame_size_is_saved_and_read_back(tmp_path):
    assert _controller().frame_size == (640, 480)
    half = _controller((320, 240))
    half.save(tmp_path / "c.json")
    data = json.loads((tmp_path / "c.json").read_text())
    assert data["schema_version"] == 8 and data["frame_size"] == [320, 240]
    assert Controller.load(tmp_path / "c.json").frame_size == (320, 240)
    assert half.relabelled("x", None).frame_size == (320, 240)


def test_a_schema_5_file_learned_on_the_paper_s_640_by_480():
    data = json.loads((DATA / "schema5_controller.json").read_text())
    assert data["schema_version"] == 5 and "frame_size" not in data
    assert Controller.load(DATA / "schema5_controller.json").frame_size == (640, 480)


@pytest.mark.parametrize("size", [(321, 240), (320, 241), (640.0, 480), [640, 480], (0, 0)])
def test_a_frame_size_the_grid_does_not_divide_is_refused(size):
    with pytest.raises(ValueError, match="frame_size"):
        Controller(_controller().library, np.zeros(n_weights(False, 40)), frame_size=size)


def test_a_method_records_its_preset_s_frame_size(tmp_path):
    assert MethodContext(tmp_path, 0, 0).frame_size == (640, 480)
    assert MethodContext(tmp_path, 0, 0, preset="paper_fast").frame_size == (320, 240)


def test_driving_at_another_size_prints_one_line_naming_both(capsys, monkeypatch):
    monkeypatch.setattr(perception_module, "_SIZES_REPORTED", set())
    controller = _controller()
    rng = np.random.default_rng(0)
    full = rng.integers(0, 256, (480, 640, 3), dtype=np.uint8)
    half = rng.integers(0, 256, (240, 320, 3), dtype=np.uint8)
    controller.act(full)
    assert capsys.readouterr().err == ""
    command = controller.act(half)  # it drives
    assert command in (0, 1, 2)
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 1
    assert "640 x 480" in lines[0] and "320 x 240" in lines[0]
    controller.act(half)
    controller.perception().perceive(half)  # a new perception: still reported once per process
    assert capsys.readouterr().err == ""
