"""Memory settings: one class per kind, one set of defaults and bounds read by every reader."""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import pytest

from lfd_track.cli.types import add_map_arguments, memory_from_args
from lfd_track.errors import FileFormatError
from lfd_track.policy.memory_config import (
    MEMORY_CONFIGS,
    MEMORY_KINDS,
    REMOVED_SETTINGS,
    FreshFeltConfig,
    LastBendConfig,
    MemoryConfig,
    NoMemory,
    PreviousCommandConfig,
    memory_config,
    memory_table_from_v1,
    setting_specs,
)
from lfd_track.study.spec import load_study

REPO = Path(__file__).resolve().parents[2]
CHOSEN = REPO / "benchmarks" / "experiments" / "goal" / "distilled.toml"
NUMBERS = [
    (cls, spec)
    for cls in MEMORY_CONFIGS.values()
    for spec in setting_specs(cls)
    if spec.type in (int, float)
]
WORDS = [spec for spec in setting_specs(FreshFeltConfig) if spec.choices]


def test_each_kind_has_its_class_and_the_factory_picks_it():
    assert MEMORY_KINDS == ("none", "last_bend", "previous_command", "fresh_felt")
    for kind, cls in MEMORY_CONFIGS.items():
        config = memory_config({"kind": kind})
        assert type(config) is cls and config.kind == kind and config == cls()
        assert MemoryConfig.from_dict(config.to_dict()) == config
        assert config.policy_inputs == 40 + config.n_inputs
    assert memory_config({}) == NoMemory()  # no kind: no memory
    assert [c.n_inputs for c in MEMORY_CONFIGS.values()] == [0, 1, 3, 3]
    with pytest.raises(TypeError, match="use memory_config"):
        MemoryConfig()


def test_every_setting_has_a_one_line_description_and_units_where_it_has_any():
    for cls in MEMORY_CONFIGS.values():
        for spec in setting_specs(cls):
            assert spec.doc and "\n" not in spec.doc
            if spec.name.endswith("_m"):
                assert spec.doc.startswith("[m]"), spec.name
            if spec.name.endswith("_deg"):
                assert spec.doc.startswith("[deg]"), spec.name
            assert spec.problem(spec.default) is None, spec.name  # the defaults are in bounds
            assert spec.problem(spec.before) is None, spec.name
    # a table written before a setting existed is read with the value it had then
    assert memory_table_from_v1({"kind": "fresh_felt"}) == FreshFeltConfig.plain().to_dict()


@pytest.mark.parametrize(
    ("table", "message"),
    [
        ({"kind": "last_turns"}, "memory kind must be one of none, last_bend, previous_comm"),
        (
            {"kind": "none", "bend_pivots": 2},
            "unknown memory setting 'bend_pivots' for kind 'none'",
        ),
        ({"kind": "previous_command", "reach_m": 1.0}, "unknown memory setting 'reach_m'"),
        ({"kind": "last_bend", "strip_link_m": 0.1}, "unknown memory setting 'strip_link_m'"),
        ({"kind": "fresh_felt", "frames": 25}, "unknown memory setting 'frames'"),
        ({"kind": "fresh_felt", "path_places": "forward"}, "unknown memory setting 'path_pla"),
        ({"kind": "fresh_felt", "blank_reach_m": 0.5}, r"blank_reach_m must be 0 \(off\) or above"),
        ({"kind": "fresh_felt", "reach_m": 0.0}, "memory reach_m must be a finite number > 0"),
        ({"kind": "fresh_felt", "strip_picture_links": 1}, "must be true or false, got 1"),
        ({"kind": "fresh_felt", "blank_bearing": "left"}, "must be one of centre, last"),
        ({"kind": "last_bend", "bend_pivots": 2}, "unknown memory setting 'bend_pivots' for kind"),
    ],
)
def test_unknown_keys_and_bad_values_are_refused_in_one_line(table, message):
    with pytest.raises(ValueError, match=message) as caught:
        memory_config(table)
    assert "\n" not in str(caught.value)


@pytest.mark.parametrize(("cls", "spec"), NUMBERS, ids=lambda x: getattr(x, "name", ""))
def test_a_number_just_beyond_its_declared_bounds_is_refused(cls, spec):
    step = 1 if spec.type is int else 1e-9
    inside = [v for v in (spec.low, spec.high) if v is not None and not spec.low_open]
    outside = [v - step for v in (spec.low,) if v is not None and not spec.low_open]
    outside += [spec.low] if spec.low_open else []
    outside += [spec.high + step] if spec.high is not None else []
    assert outside, f"{spec.name} declares no bound"
    for value in outside:
        with pytest.raises(ValueError, match=f"memory {spec.name} must be"):
            memory_config({"kind": cls.kind, spec.name: value, **_room(spec.name, value)})
    for value in inside:
        memory_config({"kind": cls.kind, spec.name: value, **_room(spec.name, value)})


def _room(name: str, value: float) -> dict[str, float]:
    """Other settings that let ``name`` take ``value`` (blank_reach_m must stay above reach_m)."""
    if name == "reach_m":
        return {"blank_reach_m": 0.0}
    if name == "blank_reach_m":
        return {"reach_m": min(0.6, value / 2)} if value > 0 else {}
    return {}


def _parse(*flags: str) -> MemoryConfig:
    parser = argparse.ArgumentParser(exit_on_error=False)
    parser.add_argument("--memory", default="none")
    add_map_arguments(parser)
    return memory_from_args(parser.parse_args(list(flags)))


def _flag(name: str) -> str:
    return "--" + name.removesuffix("_m").removesuffix("_deg").replace("_", "-")


MAP_NUMBERS = [(cls, spec) for cls, spec in NUMBERS if cls is FreshFeltConfig]


@pytest.mark.parametrize(("cls", "spec"), MAP_NUMBERS, ids=lambda x: getattr(x, "name", ""))
def test_the_command_line_takes_its_bounds_from_the_class(cls, spec):
    """At each declared bound the flag and the study table give the same settings, and a hair
    beyond it both refuse: a second copy of a bound anywhere would fail here."""
    assert spec.low is not None and spec.high is not None  # every number of the map is bounded
    bounds = [b for b in (spec.low, spec.high) if b is not None]
    for bound in bounds:
        room = _room(spec.name, bound)
        extra = [a for k, v in room.items() for a in (_flag(k), str(v))]
        study = {"kind": "fresh_felt", spec.name: bound, **room}
        if spec.low_open and bound == spec.low:
            with pytest.raises((ValueError, argparse.ArgumentError)):
                _parse("--memory", "fresh_felt", _flag(spec.name), str(bound), *extra)
            with pytest.raises(ValueError):
                memory_config(study)
            continue
        flags = _parse("--memory", "fresh_felt", _flag(spec.name), repr(bound), *extra)
        assert flags == memory_config(study)
    for beyond in (spec.low - 1e-6, spec.high + 1e-6):
        with pytest.raises((ValueError, argparse.ArgumentError)):
            _parse("--memory", "fresh_felt", _flag(spec.name), repr(beyond))
        with pytest.raises(ValueError):
            memory_config({"kind": "fresh_felt", spec.name: beyond})


def test_the_command_line_and_a_study_table_give_the_same_map(tmp_path):
    flags = _parse(
        "--memory", "fresh_felt", "--blank-bearing", "centre", "--bearing-range", "180",
        "--strip-link", "0.2", "--strip-from", "nearest", "--no-strip-picture-links",
        "--blank-reach", "1.5", "--blank-distance", "blank_reach", "--visited-fade", "0",
        "--path-radius", "0.3", "--reach", "0.8",
    )  # fmt: skip
    study = tmp_path / "study.toml"
    study.write_text(
        '[study]\nschema = 3\nseeds = [0]\nrepetitions = 1\n[[conditions]]\nname = "a"\n'
        '[conditions.memory]\nkind = "fresh_felt"\nblank_bearing = "centre"\n'
        'bearing_range_deg = 180.0\nstrip_link_m = 0.2\nstrip_from = "nearest"\n'
        'strip_picture_links = false\nblank_reach_m = 1.5\nblank_distance = "blank_reach"\n'
        "visited_fade_m = 0\npath_radius_m = 0.3\nreach_m = 0.8\n"
    )
    assert load_study(study, check_names=False).conditions[0].config.memory == flags
    assert _parse("--memory", "fresh_felt") == FreshFeltConfig()  # no flag: the defaults
    assert _parse("--memory", "last_bend") == LastBendConfig()
    with pytest.raises(ValueError, match="--strip-link is a setting of the fresh_felt map"):
        _parse("--memory", "previous_command", "--strip-link", "0.1")
    # every setting of the map has its flag
    parser = argparse.ArgumentParser()
    add_map_arguments(parser)
    dests = {a.dest for a in parser._actions} - {"help"}
    assert dests == {f.name for f in dataclasses.fields(FreshFeltConfig)}


def test_kind_fresh_felt_alone_is_the_chosen_configurations_map(tmp_path):
    chosen = load_study(CHOSEN, check_names=False).conditions[0].config.memory
    # a committed schema-2 study: its map had the paper's geometry, as every map then
    assert chosen == FreshFeltConfig(geometry="paper")
    assert FreshFeltConfig() == memory_config({"kind": "fresh_felt"})
    assert FreshFeltConfig().geometry == "world"
    assert chosen.to_dict() == {
        "kind": "fresh_felt",
        "path_radius_m": 0.35,
        "reach_m": 0.6,
        "blank_bearing": "last",
        "bearing_range_deg": 30.0,
        "strip_link_m": 0.15,
        "strip_from": "axle",
        "strip_picture_links": True,
        "blank_reach_m": 1.0,
        "blank_distance": "reach",
        "visited_fade_m": 0.3,
        "fresh_sight_m": 0.0,
        "visited_from": "path",
        "geometry": "paper",
        "felt_levels": "fixed",
        "colour_balance": "none",
        "motion": "nominal",
        "registration": "full",
        "branch_side": False,
        "branch_window": "forward",
        "branch_turn": False,
        "branch_turn_from": "set",
    }
    # a schema-1 study with the same one line meant the map with every option off
    old = tmp_path / "old.toml"
    old.write_text(
        '[study]\nseeds = [0]\nrepetitions = 1\n[[conditions]]\nname = "a"\n'
        '[conditions.memory]\nkind = "fresh_felt"\n'
    )
    assert load_study(old, check_names=False).conditions[0].config.memory == FreshFeltConfig.plain()
    old.write_text(old.read_text().replace("[study]\n", "[study]\nschema = 4\n"))
    with pytest.raises(FileFormatError, match="'study.schema' must be one of 1..3"):
        load_study(old, check_names=False)


def test_a_v1_memory_table_becomes_the_full_table_with_the_same_meaning():
    """As the old ``to_dict`` wrote them: options left out while off, constants always there."""
    constants = {"bend_pivots": 2, **REMOVED_SETTINGS["fresh_felt"]}
    v1 = {"kind": "fresh_felt", **constants, "path_radius_m": 0.3, "reach_m": 0.8}
    assert (
        memory_table_from_v1(v1) == FreshFeltConfig.plain(path_radius_m=0.3, reach_m=0.8).to_dict()
    )
    chosen = {
        **v1,
        "path_radius_m": 0.35,
        "reach_m": 0.6,
        "blank_bearing": "last",
        "bearing_range_deg": 30.0,
        "strip_link_m": 0.15,
        "blank_reach_m": 1.0,
        "visited_fade_m": 0.3,
        "blank_distance": "reach",
        "strip_picture_links": True,
    }
    assert memory_table_from_v1(chosen) == FreshFeltConfig(geometry="paper").to_dict()
    assert memory_table_from_v1({"kind": "last_bend", "bend_pivots": 2}) == {"kind": "last_bend"}
    with pytest.raises(ValueError, match="memory bend_pivots = 3 is no longer supported"):
        memory_table_from_v1({"kind": "last_bend", "bend_pivots": 3})
    assert memory_table_from_v1({"kind": "none", "bend_pivots": 2}) == {"kind": "none"}
    assert memory_table_from_v1({"kind": "previous_command", "bend_pivots": 2}) == {
        "kind": "previous_command"
    }
    for config in (FreshFeltConfig(), FreshFeltConfig.plain(), LastBendConfig(), NoMemory()):
        assert memory_table_from_v1(config.to_dict()) == config.to_dict()  # full: unchanged
    assert PreviousCommandConfig().to_dict() == {"kind": "previous_command"}
    with pytest.raises(ValueError, match="memory frames = 30 is no longer supported"):
        memory_table_from_v1({"kind": "fresh_felt", "frames": 30})
    with pytest.raises(ValueError, match="memory path_places = 'forward' is no longer supp"):
        memory_table_from_v1({"kind": "fresh_felt", "path_places": "forward"})
    with pytest.raises(ValueError, match="unknown memory setting 'pivots'"):
        memory_table_from_v1({"kind": "last_bend", "pivots": 2})


def test_the_learning_api_page_names_every_map_flag():
    """docs/learning-api.md lists the map's flags by hand; a setting added without its flag there
    fails here (a boolean setting is listed as ``--[no-]name``)."""
    page = (REPO / "docs" / "learning-api.md").read_text(encoding="utf-8")
    for spec in setting_specs(FreshFeltConfig):
        flag = _flag(spec.name)
        listed = f"`{flag}`" in page or f"`--[no-]{flag[2:]}`" in page
        assert listed, f"docs/learning-api.md does not list {flag}"
