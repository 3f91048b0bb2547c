"""results.json schemas: every committed file reads as the current schema, its trial outcomes
valid by the one definition and its settings whole; each schema-1 omission means what it meant."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import pytest

from lfd_track.benchmark.runner import BenchmarkConfig, config_dict
from lfd_track.benchmark.schema import (
    RESULTS_FORMAT,
    RESULTS_SCHEMA,
    migrate_results,
    read_results,
    results_v1_to_v2,
)
from lfd_track.benchmark.tables import TrialOutcome, build_results, results_json_text
from lfd_track.errors import FileFormatError
from lfd_track.methods.dagger import DaggerConfig
from lfd_track.policy.memory_config import memory_table_from_v1
from lfd_track.study.summary import check_job_results, human_commands

REPO = Path(__file__).resolve().parents[2]
COMMITTED = sorted(str(p.relative_to(REPO)) for p in (REPO / "benchmarks").rglob("results.json"))


def _stored(value):
    """``value`` as results.json stores it (tuples as lists, floats rounded)."""
    return json.loads(results_json_text({"x": value}))["x"]


def test_there_are_committed_results_and_all_are_schema_1_3_to_12_or_current():
    assert len(COMMITTED) >= 270
    schemas = {json.loads((REPO / f).read_text(encoding="utf-8"))["schema"] for f in COMMITTED}
    # 3: before the fresh-felt map's geometry setting; 4: before its motion setting; 5: before
    # its branch_side setting; 6: before its branch_window setting; 7: before its branch_turn
    # setting; 8: before branch_turn_from; 9: before colour_balance; 10: before registration;
    # 11: before visited_from; 12: before fresh_sight_m
    assert schemas <= {1, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, RESULTS_SCHEMA}
    assert RESULTS_FORMAT.current == RESULTS_SCHEMA  # one step per schema after the first


@pytest.mark.parametrize("path", COMMITTED)
def test_a_committed_results_json_reads_as_the_current_schema(path):
    results = read_results(REPO / path)
    assert results["schema"] == RESULTS_SCHEMA == 13
    for index, outcome in enumerate(results["outcomes"]):
        TrialOutcome.from_dict(outcome, f"outcomes[{index}]")
    if "rule" in results:
        # A hand-written rule scored on a study's trials (generalization/rules.py): it learns
        # nothing and has no benchmark configuration, only the rule's own settings.
        assert set(results["rule"]) == {"name", "config"} and "config" not in results
        assert results["rule"]["name"] in {"road-rule", "map-rule"}
        return
    config = results["config"]
    # Every setting, and exactly the settings this version writes for that configuration.
    assert _stored(config_dict(BenchmarkConfig.from_dict(config))) == config
    # Valid as the study reads a job (every trial once), with the command count in one place.
    check_job_results(
        results,
        config["repetitions"],
        config["trials_per_direction"],
        config["test_tracks"],
        config.get("random_loops", 0),
    )
    assert human_commands(results) == results["human_effort"]["total"]["commands"]


def test_the_paper_protocol_file_means_the_paper_protocol_configuration():
    results = read_results(
        REPO / "benchmarks/experiments/paper_protocol/results/seed0/results.json"
    )
    assert results["config"] == _stored(config_dict(BenchmarkConfig(repetitions=10, seed=0)))


V1_CONFIG = {  # what schema 1 stored for a paper run without any option beyond the paper's
    "repetitions": 1,
    "seed": 3,
    "trials_per_direction": 3,
    "preset": "paper",
    "keep_learning": False,
    "method": "paper",
    "test_tracks": ["testing"],
    "human": {
        "careful": True,
        "dead_band_deg": 15.0,
        "first_turnaround": "left",
        "lapse_prob": 0.03,
        "legs": 4,
        "library_only_commands": 10,
        "lookahead_m": 0.35,
        "max_commands": 1000,
        "reaction_delay_prob": 0.1,
        "stop_before_end_m": 0.35,
    },
}


def test_schema_1_settings_left_out_take_the_values_they_had():
    config = results_v1_to_v2({"schema": 1, "config": copy.deepcopy(V1_CONFIG)})["config"]
    assert config["human"] | {"turnarounds": "alternate"} == config["human"]
    assert {k: config["human"][k] for k in ("steers_by", "picture_turn_deg")} == {
        "steers_by": "centreline",
        "picture_turn_deg": 20.0,
    }
    assert config["human"]["clear_memory_per_leg"] is False
    assert config["dagger"] == _stored(DaggerConfig().to_dict())
    assert config["memory"] == memory_table_from_v1({"kind": "none"})
    assert (config["mirror"], config["shifted_views"]) == (False, False)
    assert (config["policy_kind"], config["demo_track"], config["features"]) == (
        "mlp-sigmoid",
        "training",
        "road_values",
    )


def test_a_schema_1_fresh_felt_table_keeps_the_options_it_left_out_off():
    v1 = {"kind": "fresh_felt", "bend_pivots": 2, "reach_m": 0.6, "path_radius_m": 0.35}
    config = results_v1_to_v2({"config": {**V1_CONFIG, "memory": v1}})["config"]
    memory = config["memory"]
    assert memory["kind"] == "fresh_felt"
    assert memory["strip_link_m"] == 0.0 and memory["blank_reach_m"] == 0.0
    assert memory["blank_bearing"] == "centre" and memory["bearing_range_deg"] == 180.0


@pytest.mark.parametrize(
    "spelling",
    [
        {"effort": {"total": {"human_commands": 42}, "repetitions": [{"human_commands": 42}]}},
        {"human": {"total": {"commands": 42}}},
        {"human": {"commands": 42}},
        {"human_commands": 42},
        {"human_effort": {"total": {"commands": 42}}},
    ],
)
def test_every_schema_1_spelling_of_the_command_count_becomes_one(spelling):
    results = migrate_results({"schema": 1, **spelling}, "results.json")
    assert results["human_effort"]["total"]["commands"] == 42
    assert not {"effort", "human", "human_commands"} & set(results)
    assert human_commands(results) == 42


def test_migration_leaves_its_input_as_it_was():
    data = {"schema": 1, "config": copy.deepcopy(V1_CONFIG)}
    migrate_results(data, "results.json")
    assert data == {"schema": 1, "config": V1_CONFIG}


def test_a_newer_schema_fails_in_one_line_naming_the_file(tmp_path):
    path = tmp_path / "results.json"
    path.write_text(json.dumps({"schema": RESULTS_SCHEMA + 1}))
    with pytest.raises(FileFormatError) as exc:
        read_results(path)
    message = str(exc.value)
    assert message.startswith(f"{path}: results schema {RESULTS_SCHEMA + 1} is newer")
    assert "\n" not in message


def test_a_memory_table_no_current_setting_can_mean_is_one_line_naming_the_file():
    data = {"schema": 1, "config": {**V1_CONFIG, "memory": {"kind": "sonar"}}}
    with pytest.raises(
        FileFormatError, match="^r.json: results of schema 1 cannot be read: memory"
    ):
        migrate_results(data, "r.json")


def _every_option_set() -> BenchmarkConfig:
    from lfd_track.demo.demonstrator import HumanConfig
    from lfd_track.policy.memory_config import memory_config

    return BenchmarkConfig(
        repetitions=2,
        seed=5,
        method="bc",
        human=HumanConfig(clear_memory_per_leg=True, steers_by="picture", picture_turn_deg=15.0),
        memory=memory_config({"kind": "fresh_felt"}),
        mirror=True,
        shifted_views=True,
        features="road_values+colour",
        demo_track="training",
        test_tracks=("testing", "kite"),
    )


@pytest.mark.parametrize("config", [BenchmarkConfig(), _every_option_set()], ids=["default", "set"])
def test_a_fresh_results_json_is_the_current_schema_with_every_setting(config):
    results = build_results([], repetitions=config.repetitions, seed=config.seed, timing_s={})
    results["config"] = config_dict(config)
    stored = json.loads(results_json_text(results))
    assert stored["schema"] == RESULTS_SCHEMA
    assert migrate_results(stored, "results.json") is stored  # nothing to migrate
    tables = ("human", "ga", "online", "hg_dagger", "bc", "cmaes", "dagger", "memory")
    assert set(tables) <= set(stored["config"])
    assert set(stored["config"]) == set(_stored(config_dict(BenchmarkConfig())))
    assert BenchmarkConfig.from_dict(stored["config"]) == config
