"""Property tests of the controller file parser: values replaced, characters changed, random bytes.

For any input the parser returns a valid object or refuses the file in one line naming it
(``parser_property_support``); ``-s`` prints how many inputs each property tried.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from parser_property_support import SETTINGS, outcome, print_counts

from lfd_track.policy.controller import MAX_ABS_WEIGHT, Controller, checksum
from lfd_track.vision.road_library import RoadLibrary


@pytest.fixture(scope="module", autouse=True)
def _report_counts():
    yield
    print_counts()


def _controller_dict() -> dict:
    rng = np.random.default_rng(1)
    library = RoadLibrary(bins=4)
    library.learn_model(rng.random((5, 4)).astype(np.float32))
    controller = Controller(library, rng.uniform(-2, 2, 215), learner="bc", seed=3)
    return json.loads(json.dumps(controller.to_dict()))


JSON_VALUES = st.recursive(
    st.none()
    | st.booleans()
    | st.integers(-(10**30), 10**30)
    | st.floats(allow_nan=False, allow_infinity=False)
    | st.text(max_size=8),
    lambda children: (
        st.lists(children, max_size=4) | st.dictionaries(st.text(max_size=6), children, max_size=4)
    ),
    max_leaves=12,
)


def _load_controller(path: Path) -> Controller:
    controller = Controller.load(path)
    w = controller.weights
    assert np.isfinite(w).all() and np.abs(w).max() <= MAX_ABS_WEIGHT
    assert controller.library.n_models > 0
    return controller


@SETTINGS
@given(st.sampled_from(sorted(_controller_dict())), JSON_VALUES)
def test_controller_with_one_value_replaced(tmp_path, key, value):
    data = _controller_dict()
    data[key] = value
    data["checksum"] = checksum(data)  # a well-formed file with a wrong value behind the checksum
    path = tmp_path / "c.json"
    path.write_text(json.dumps(data))
    outcome("controller: one value replaced, checksum fixed", path, _load_controller)


@SETTINGS
@given(st.integers(0, 10**7), st.characters(codec="utf-8"))
def test_controller_with_one_character_changed(tmp_path, where, char):
    text = json.dumps(_controller_dict(), separators=(",", ":"))
    i = where % len(text)
    path = tmp_path / "c.json"
    path.write_text(text[:i] + char + text[i + 1 :])
    loaded = outcome("controller: one character changed", path, _load_controller)
    if loaded is not None:  # accepted only if nothing changed in meaning
        assert loaded.to_dict() == _controller_dict()


@SETTINGS
@given(st.binary(max_size=2000))
def test_any_bytes_as_a_controller(tmp_path, data):
    path = tmp_path / "c.json"
    path.write_bytes(data)
    outcome("controller: random bytes", path, _load_controller)
