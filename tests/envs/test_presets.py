"""Preset files: every value range-checked, randomization ranges checked jointly, odd bytes."""

from __future__ import annotations

import dataclasses
import os
import re
import typing
from pathlib import Path

import numpy as np
import pytest
from lfd_test_support import REPO

from lfd_track.envs.presets import BOUNDS, SECTIONS, load_preset
from lfd_track.errors import FileFormatError

README = REPO / "envs" / "README.md"


def _numeric_fields():
    for section, cls in SECTIONS.items():
        hints = typing.get_type_hints(cls)
        for f in dataclasses.fields(cls):
            hint = hints[f.name]
            elem = typing.get_args(hint)[0] if typing.get_origin(hint) is tuple else hint
            if elem in (int, float):
                yield section, f.name, getattr(cls(), f.name)


def test_every_numeric_value_has_bounds_that_hold_the_defaults():
    names = set()
    for section, key, default in _numeric_fields():
        name = f"{section}.{key}"
        names.add(name)
        low, high = BOUNDS[name]
        for v in default if isinstance(default, tuple) else (default,):
            assert low <= v <= high, name
    assert names == set(BOUNDS)


def test_readme_states_every_bound():
    text = README.read_text()
    rows = dict(re.findall(r"^\| `([a-z_]+\.[a-z_0-9]+)` \| (\S+ \| \S+) \|", text, re.M))
    for name, (low, high) in BOUNDS.items():
        assert rows.get(name) == f"{low:g} | {high:g}", name


def _refused(path: Path | str, problem: str) -> str:
    with pytest.raises(FileFormatError) as info:
        load_preset(path)
    message = str(info.value)
    assert message.startswith(f"{path}: ") and "\n" not in message
    assert problem in message, message
    return message


@pytest.mark.parametrize(
    ("text", "problem"),
    [
        # Each of these loaded in wave 1 and then hung or exhausted memory in the env.
        ("[rover]\nphysics_dt_s = 1e-7\n", "'rover.physics_dt_s' = 1e-07 is outside [0.001, 0.05]"),
        ("[rover]\ncontrol_period_s = 1e5\n", "'rover.control_period_s' = 100000.0 is outside"),
        (
            "[lighting]\npool_count = 1000000\n",
            "'lighting.pool_count' = 1000000 is outside [0, 20]",
        ),
        ("[lighting]\nshadow_count = 1000000\n", "'lighting.shadow_count'"),
        ("[lighting]\ngrid_m = 1e-6\n", "'lighting.grid_m' = 1e-06 is outside [0.005, 0.5]"),
        ("[sensor]\nnoise_pool_frames = 100000\n", "'sensor.noise_pool_frames'"),
        ("[camera]\nheight_m = 500.0\n", "'camera.height_m' = 500.0 is outside [0.05, 2]"),
        (
            "[rover]\ncontrol_period_s = 5.0\nphysics_dt_s = 0.001\n",
            "5000 physics substeps per command, more than 1000",
        ),
        ('[randomization]\n"lighting.grid_m" = [1e-6, 0.02]\n', "reaches outside [0.005, 0.5]"),
        ("[rover]\nmass_kg = 1" + "0" * 400 + "\n", "'rover.mass_kg' must be finite"),
        ("[rover]\ncalibration_commands = 1" + "0" * 5000 + "\n", "not valid TOML"),
        ("x = " + "[" * 200_000 + "]" * 200_000 + "\n", "TOML"),
        # Integers too large for a float: an OverflowError with no file name before.
        ('[randomization]\n"rover.mass_kg" = [1, 1' + "0" * 400 + "]\n", "must be numbers"),
        ("description = 5\n", "'description' must be a string"),
    ],
)
def test_absurd_values_are_refused_naming_the_file(tmp_path, text, problem):
    path = tmp_path / "absurd.toml"
    path.write_text(text)
    _refused(path, problem)


def test_randomization_ranges_are_checked_jointly(tmp_path):
    # Each end is valid with the other field at its default, but pitch 22 with vfov 45 puts the
    # horizon in view: wave 1 loaded this and reset(seed=87) failed mid-run.
    path = tmp_path / "joint.toml"
    path.write_text(
        '[randomization]\n"camera.pitch_deg" = [22.0, 34.0]\n"camera.vfov_deg" = [38.0, 45.0]\n'
    )
    message = _refused(path, "randomization can draw")
    assert "camera.pitch_deg = 22.0" in message and "camera.vfov_deg = 45.0" in message
    assert "horizon" in message
    path.write_text(
        '[randomization]\n"camera.pitch_deg" = [24.0, 34.0]\n"camera.vfov_deg" = [38.0, 45.0]\n'
    )
    assert load_preset(path).randomized


def test_every_draw_of_the_shipped_randomized_preset_is_valid():
    preset = load_preset("randomized")
    rng = np.random.default_rng(0)
    for _ in range(300):
        drawn = preset.sample(rng)  # constructing the configs runs their checks
        for section, key, _ in _numeric_fields():
            value = getattr(getattr(drawn, section), key)
            low, high = BOUNDS[f"{section}.{key}"]
            assert all(low <= v <= high for v in (value if isinstance(value, tuple) else (value,)))


def test_non_utf8_fifo_and_device_are_refused(tmp_path):
    path = tmp_path / "latin1.toml"
    path.write_bytes('name = "f\xfcr den Flur"\n'.encode("latin-1"))
    _refused(path, "not UTF-8")
    fifo = tmp_path / "fifo.toml"
    os.mkfifo(fifo)
    _refused(fifo, "not a regular file")
    _refused("/dev/zero", "not a regular file")


def test_a_name_longer_than_the_file_system_allows_is_a_one_line_error():
    from lfd_track.errors import LfdTrackError

    for name in ("x" * 5000, "x" * 5000 + ".toml"):
        with pytest.raises(LfdTrackError, match="preset") as info:
            load_preset(name)
        assert "\n" not in str(info.value)
