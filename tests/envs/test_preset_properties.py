"""Property tests of the preset parser: random values and randomization ranges, random bytes.

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
from parser_property_support import NUMBERS, SETTINGS, outcome, print_counts, toml_value

from lfd_track.envs.presets import BOUNDS, SECTIONS, load_preset


@pytest.fixture(scope="module", autouse=True)
def _report_counts():
    yield
    print_counts()


FIELDS = sorted(BOUNDS)


def _check_preset(path: Path):
    preset = load_preset(path)
    drawn = preset.sample(np.random.default_rng(0))
    for name, (low, high) in BOUNDS.items():
        section, key = name.split(".")
        value = getattr(getattr(drawn, section), key)
        assert all(low <= v <= high for v in (value if isinstance(value, tuple) else (value,)))
    return preset


def _field_value(name: str):
    low, high = BOUNDS[name]
    section, key = name.split(".")
    default = getattr(SECTIONS[section](), key)
    near = (
        st.floats(low - (high - low), high + (high - low))
        if isinstance(default, float)
        else st.integers(int(low) - 5, int(high) + 5)
    )
    value = near | NUMBERS | st.booleans() | st.text(max_size=3)
    if isinstance(default, tuple):
        return st.lists(st.integers(-10, 300), min_size=2, max_size=4) | value
    return value


@SETTINGS
@given(st.data())
def test_random_preset_values(tmp_path, data):
    names = data.draw(st.lists(st.sampled_from(FIELDS), max_size=4, unique=True))
    tables: dict[str, list[str]] = {}
    for name in names:
        section, key = name.split(".")
        tables.setdefault(section, []).append(
            f"{key} = {toml_value(data.draw(_field_value(name)))}"
        )
    ranged = data.draw(st.lists(st.sampled_from(FIELDS), max_size=3, unique=True))
    lines = [f"[{s}]\n" + "\n".join(body) for s, body in tables.items()]
    if ranged:
        rows = []
        for name in ranged:
            lo, hi = data.draw(_field_value(name)), data.draw(_field_value(name))
            rows.append(f"{json.dumps(name)} = [{toml_value(lo)}, {toml_value(hi)}]")
        lines.append("[randomization]\n" + "\n".join(rows))
    path = tmp_path / "p.toml"
    path.write_text("\n".join(lines) + "\n")
    outcome("preset: random values and ranges", path, _check_preset)


@SETTINGS
@given(st.binary(max_size=1500))
def test_any_bytes_as_a_preset(tmp_path, data):
    path = tmp_path / "p.toml"
    path.write_bytes(data)
    outcome("preset: random bytes", path, _check_preset)
