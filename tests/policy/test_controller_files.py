"""Every committed controller file loads through the migrations and drives as it did.

``tests/data/schema{2,3,4}_*controller.json`` were written by the code before schema 5 (a
``fresh_felt`` memory table then left out each option that was off), together with what that
code computed with them (``schema2to4_controllers_expected.json``: the memory inputs and the
decisions over a fixed drive of road values and commands).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from lfd_track.policy.controller import Controller
from lfd_track.policy.controller_schema import CONTROLLER_SCHEMA, MIGRATIONS, migrate
from lfd_track.policy.memory import memory_for

REPO = Path(__file__).resolve().parents[2]
DATA = REPO / "tests" / "data"
COMMITTED = sorted(
    str(p.relative_to(REPO))
    for folder in ("tests", "benchmarks", "lfd_track")
    for p in (REPO / folder).rglob("*controller.json")
)
EXPECTED = json.loads((DATA / "schema2to4_controllers_expected.json").read_text())


def test_one_migration_per_schema_step():
    assert sorted(MIGRATIONS) == list(range(1, CONTROLLER_SCHEMA))
    assert len(COMMITTED) >= 6  # the first release's file and one of each later schema


@pytest.mark.parametrize("path", COMMITTED)
def test_a_committed_controller_file_loads_and_saves_as_the_current_schema(path, tmp_path):
    data = json.loads((REPO / path).read_text())
    current = migrate(data)
    assert current["schema_version"] == CONTROLLER_SCHEMA
    controller = Controller.load(REPO / path)
    controller.save(tmp_path / "c.json")
    saved = json.loads((tmp_path / "c.json").read_text())
    assert saved["schema_version"] == CONTROLLER_SCHEMA
    again = Controller.load(tmp_path / "c.json")
    assert again.memory == controller.memory and again.features == controller.features
    assert again.weights.tobytes() == controller.weights.tobytes()
    assert again.policy_kind == controller.policy_kind and again.hidden == controller.hidden
    # the migrated memory table is the full table of the settings the file meant
    memory = current["memory"]
    assert memory == (None if controller.memory is None else controller.memory.to_dict())


@pytest.mark.parametrize("name", sorted(k for k in EXPECTED if k.endswith(".json")))
def test_an_older_controller_computes_what_it_computed_when_written(name):
    expected = EXPECTED[name]
    controller = Controller.load(DATA / name)
    memory = memory_for(controller.memory)
    decisions = []
    for step, (values, command) in enumerate(
        zip(EXPECTED["road_values"], EXPECTED["commands_given"], strict=True)
    ):
        values = np.asarray(values)
        inputs = np.zeros(0)
        if memory is not None:
            memory.see(values)
            inputs = memory.inputs()
        np.testing.assert_allclose(inputs, expected["memory_inputs"][step], rtol=0, atol=1e-9)
        frame = np.zeros(0) if controller.features == "none" else values
        decisions.append(controller.act_on_values(np.concatenate([frame, inputs])))
        if memory is not None:
            memory.note(command)
    assert decisions == expected["decisions"]
