"""results.json versions: the current schema and one migration function per step from older ones.

Every reader of a results.json goes through :func:`read_results` (a file) or
:func:`migrate_results` (a dict already parsed), and reads the current schema only; the writer
(:func:`~lfd_track.benchmark.tables.build_results` and ``runner.config_dict``) always writes the
current schema in full.

Schema history:

* **1** — the ``config`` section left out every setting that was at the value it had before the
  setting existed, so that a run without it stored exactly what it stored before (human
  ``steers_by``, ``picture_turn_deg`` and ``clear_memory_per_leg``; the ``dagger`` table of the
  other methods; ``memory`` without memory, and the ``fresh_felt`` options that were off;
  ``mirror``, ``shifted_views``, ``policy_kind``, ``demo_track``, ``features``; the human's
  ``turnarounds`` before it existed). The human's command count was read from
  ``human_effort.total.commands``, from the first layout ``effort`` (``human_commands``) or,
  by the study summary, from ``human`` or ``human_commands``.
* **2** — ``config`` holds every setting; the command count is ``human_effort.total.commands``
  wherever the run reported one (a run from before the benchmark reported the human's effort has
  no ``human_effort``: its commands are its demonstrations', see
  :func:`lfd_track.study.summary.human_commands`).
* **3** — ``config`` holds the settings tables of the methods ``direct`` and ``mu-plus-one``
  (``direct``, ``mu_plus_one``), and every ``human_effort`` record (the total and each
  repetition's) counts ``put_backs``, the times the robot was put back on the felt by hand. A
  schema-2 file was written before these methods existed: its tables are their first defaults
  and its put-backs 0 (no method before them put the robot back by hand). ``config`` also holds
  ``random_loops`` and ``random_split`` (procedural loops lapped per repetition; a schema-2 run
  lapped none: 0 and ``"validation"``), and a run that lapped some has a ``random_loops``
  section (:func:`lfd_track.benchmark.loops.random_loop_results`).
* **4** — ``config.memory`` names every memory setting added since, in particular the
  ``fresh_felt`` map's ``geometry`` (:mod:`lfd_track.policy.map_geometry`). A schema-3 file was
  written before them: each one it lacks has the value that does what the memory did then
  (``geometry = "paper"``: the paper's camera, 0.10 m and 22.9° per command).
  ``config.room`` came later without a new schema: it is written only when it is
  ``"per_repetition"`` (one world drawn per repetition from a randomized preset), and a file
  without it means ``"per_episode"``, what every run did before (so no older file changes
  meaning, and each still matches the settings that produced it). The ``hg_dagger`` table's
  ``learner`` came the same way: written only when it is ``"bc"``; without it, ``"ga"``.
* **5** — ``config.memory`` names the ``fresh_felt`` map's ``motion`` (how it moves at each
  command: :mod:`lfd_track.policy.odometry`). A schema-4 file was written before it:
  ``"nominal"``, what every map did then (the same step as 3 -> 4: every memory setting a file
  lacks at what the memory did before the setting existed).
* **6** — ``config.memory`` names the ``fresh_felt`` map's ``branch_side`` (its fourth input). A
  schema-5 file was written before it: ``false``, what every map did then (the same step).
* **7** — ``config.memory`` names the branch side's ``branch_window``. A schema-6 file was
  written before it: ``"forward"``, what every map did then (the same step).
* **8** — ``config.memory`` names the branch side's ``branch_turn`` (a fifth input). A schema-7
  file was written before it: ``false``, what every map did then (the same step).
* **9** — ``config.memory`` names where that turn counts from, ``branch_turn_from``. A schema-8
  file was written before it: ``"set"``, what every map did then (the same step).
* **10** — ``config.memory`` names the ``fresh_felt`` map's ``colour_balance`` (how a driving
  session's frames are balanced: :mod:`lfd_track.vision.colour_balance`). A schema-9 file was
  written before it: ``"none"``, what every run did then (the same step).
* **11** — ``config.memory`` names how the map's measured motion is searched for,
  ``registration`` (:data:`lfd_track.policy.odometry.REGISTRATIONS`). A schema-10 file was
  written before it: ``"full"``, what every run did then (the same step).
* **12** — ``config.memory`` names what the map's visited felt is measured from,
  ``visited_from``. A schema-11 file was written before it: ``"path"``, what every run did then
  (the same step).
* **13** — ``config.memory`` names the cell in which the map reads whether fresh felt is in sight
  along felt, ``fresh_sight_m``. A schema-12 file was written before it: ``0.0`` (off), what
  every run did then (the same step).
"""

from __future__ import annotations

import copy
from typing import Any

from ..policy.memory_config import memory_table_from_v1
from ..utils.migrate import Step, VersionedJson

RESULTS_SCHEMA = 13
"""Schema of the results.json this version writes (``len(RESULTS_STEPS) + 1``)."""
MAX_RESULTS_BYTES = 1 << 28
"""Largest results.json read (a 10-repetition benchmark writes about 100 kB)."""

# What a schema-1 file meant by each setting it left out: the value the setting had before it
# existed (or, for a setting that only one method or one steering reads, the default it had,
# since the others never read it). Spelled out here, not read from today's defaults, which may
# change without changing what an old file meant.
_V1_CONFIG = {
    "mirror": False,
    "shifted_views": False,
    "policy_kind": "mlp-sigmoid",
    "demo_track": "training",
    "features": "road_values",
}
_V1_HUMAN = {
    "turnarounds": "alternate",
    "steers_by": "centreline",
    "picture_turn_deg": 20.0,
    "clear_memory_per_leg": False,
}
_V1_INTERVENTION = {
    "heading_error_deg": 35.0,
    "tread_overhang_m": 0.03,
    "progress_drop_m": 0.1,
    "stall_commands": 8,
    "stall_progress_m": 0.05,
}
_V1_DAGGER = {
    "window": 10,
    "threshold": 0.9,
    "intervention": _V1_INTERVENTION,
    "rounds": 3,
    "learner": "ga",
    "hidden": 5,
    "label_noise": False,
}


def _filled(table: Any, meant: dict[str, Any]) -> Any:
    """``table`` with every key of ``meant`` it lacks (a table that is not a dict is left as it
    is, for the reader's own checks to name)."""
    if not isinstance(table, dict):
        return table
    return {**copy.deepcopy(meant), **table}


def memory_v1_to_v2(memory: Any) -> dict[str, Any]:
    """A schema-1 ``memory`` table (``None`` when the file had none: no memory) as a full
    table of today's settings with the same meaning (``ValueError`` if it cannot have one)."""
    return memory_table_from_v1({"kind": "none"} if memory is None else memory)


def config_v1_to_v2(config: Any) -> Any:
    """A schema-1 ``config`` section with every setting it left out, at what it meant then.

    Also the conditions' ``config`` of a schema-1 study.json (which have no seed or repetitions).
    """
    if not isinstance(config, dict):
        return config
    out = _filled(config, _V1_CONFIG)
    out["human"] = _filled(out.get("human", {}), _V1_HUMAN)
    out["dagger"] = _filled(out.get("dagger", {}), _V1_DAGGER)
    out["memory"] = memory_v1_to_v2(out.get("memory"))
    return out


def _effort_v1_to_v2(data: dict[str, Any]) -> None:
    """The human's command count as ``human_effort.total.commands``, whichever way schema 1
    spelled it (``human_effort`` itself is left for the reader's checks)."""
    if "human_effort" in data:
        return
    effort = data.pop("effort", None)
    if isinstance(effort, dict):  # the first layout: "human_commands" where "commands" is now
        records = effort.get("repetitions")
        for record in [effort.get("total"), *(records if isinstance(records, list) else [])]:
            if isinstance(record, dict) and "human_commands" in record:
                record["commands"] = record.pop("human_commands")
        data["human_effort"] = effort
        return
    human = data.get("human")
    if isinstance(human, dict):
        total = human.get("total", human)
        if isinstance(total, dict) and "commands" in total:
            data["human_effort"] = {"total": dict(total)}
            del data["human"]
            return
    if "human_commands" in data:
        data["human_effort"] = {"total": {"commands": data.pop("human_commands")}}


def results_v1_to_v2(data: dict[str, Any]) -> dict[str, Any]:
    """Schema 1 -> 2: every setting in ``config``; the command count in one place."""
    if "config" in data:
        data["config"] = config_v1_to_v2(data["config"])
    _effort_v1_to_v2(data)
    data["schema"] = 2
    return data


# The settings the methods "direct" and "mu-plus-one" had when they were registered (schema 3):
# what a schema-2 file, written before they existed, means by the tables it lacks.
_V2_DIRECT = {
    "population_size": 10,
    "generations": 25,
    "robot_budget_s": 4000.0,
    "stall_steps": 25,
    "stall_m": 0.05,
}
_V2_MU_PLUS_ONE = {
    "mu": 10,
    "tau": 50,
    "recovery": 10,
    "reevaluation": 0.2,
    "sigma_min": 0.1,
    "sigma_max": 1.6,
    "init_range": 1.0,
    "evaluations": 500,
    "robot_budget_s": 4000.0,
    "put_back_penalty_m": 1.0,
    "end_margin_m": 0.4,
}


def config_v2_to_v3(config: Any) -> Any:
    """A schema-2 ``config`` section with the ``direct`` and ``mu_plus_one`` tables and no
    procedural loops (``random_loops`` 0; also the conditions' ``config`` of a schema-2
    study.json)."""
    if not isinstance(config, dict):
        return config
    out = dict(config)
    out["direct"] = _filled(out.get("direct", {}), _V2_DIRECT)
    out["mu_plus_one"] = _filled(out.get("mu_plus_one", {}), _V2_MU_PLUS_ONE)
    out.setdefault("random_loops", 0)  # no procedural loops before schema 3
    out.setdefault("random_split", "validation")
    return out


def results_v2_to_v3(data: dict[str, Any]) -> dict[str, Any]:
    """Schema 2 -> 3: the new methods' settings tables; ``put_backs`` 0 in every effort record."""
    if "config" in data:
        data["config"] = config_v2_to_v3(data["config"])
    effort = data.get("human_effort")
    if isinstance(effort, dict):
        records = effort.get("repetitions")
        for record in [effort.get("total"), *(records if isinstance(records, list) else [])]:
            if isinstance(record, dict):
                record.setdefault("put_backs", 0)
    data["schema"] = 3
    return data


def config_v3_to_v4(config: Any) -> Any:
    """A schema-3 or schema-4 ``config`` section whose memory table names every setting of
    today, each one it lacks at the value that does what the memory did before the setting
    existed (steps 3 -> 4 and 4 -> 5; also the conditions' ``config`` of a study.json of those
    schemas)."""
    if not isinstance(config, dict) or not isinstance(config.get("memory"), dict):
        return config
    return {**config, "memory": memory_table_from_v1(config["memory"])}


def results_v3_to_v4(data: dict[str, Any]) -> dict[str, Any]:
    """Schema 3 -> 4: the memory settings added since, at what an older run did."""
    if "config" in data:
        data["config"] = config_v3_to_v4(data["config"])
    data["schema"] = 4
    return data


def _memory_settings_added(data: dict[str, Any], schema: int) -> dict[str, Any]:
    """``data`` with the memory settings its ``config`` lacks at what an older run did (the step
    3 -> 4 makes), as schema ``schema``."""
    if "config" in data:
        data["config"] = config_v3_to_v4(data["config"])
    data["schema"] = schema
    return data


#: The memory setting each schema from 5 on added to ``config.memory`` (a file of the schema
#: before lacks it, and means the value that does what the memory did before the setting
#: existed: the step fills it as the step 3 -> 4 fills every one). A memory setting added later
#: is one more entry here (and one more schema).
MEMORY_SETTING_SINCE: dict[int, str] = {
    5: "motion",
    6: "branch_side",
    7: "branch_window",
    8: "branch_turn",
    9: "branch_turn_from",
    10: "colour_balance",
    11: "registration",
    12: "visited_from",
    13: "fresh_sight_m",
}


def _memory_step(schema: int) -> Step:
    """The step ``schema - 1`` -> ``schema``: the memory settings added since
    (:data:`MEMORY_SETTING_SINCE`), at what an older run did."""

    def step(data: dict[str, Any]) -> dict[str, Any]:
        return _memory_settings_added(data, schema)

    step.__name__ = step.__qualname__ = f"results_v{schema - 1}_to_v{schema}"
    step.__doc__ = (
        f"Schema {schema - 1} -> {schema}: the memory settings added since"
        f" (``{MEMORY_SETTING_SINCE[schema]}``), at what an older run did."
    )
    return step


RESULTS_STEPS: tuple[Step, ...] = (
    results_v1_to_v2,
    results_v2_to_v3,
    results_v3_to_v4,
    *(_memory_step(schema) for schema in sorted(MEMORY_SETTING_SINCE)),
)
"""Step k turns a schema-k results dict into schema k + 1."""
RESULTS_FORMAT = VersionedJson("results", RESULTS_STEPS, MAX_RESULTS_BYTES)
"""results.json: its steps and largest size; :func:`read_results` (a file) and
:func:`migrate_results` (a dict already parsed) are its ``read`` and ``migrate``."""
migrate_results = RESULTS_FORMAT.migrate
read_results = RESULTS_FORMAT.read
