"""The controller file's schemas: the keys of each, one migration per schema step, and the checks
of the fields a file holds as plain JSON (its weights, a GA's settings).

A file of schema k is turned into one of schema k + 1 meaning the same controller by
``MIGRATIONS[k]`` (:func:`migrate` runs them up to :data:`CONTROLLER_SCHEMA`, after checking the
file's keys and, from schema 2 on, its checksum); :mod:`lfd_track.policy.controller` reads the
result. What each schema added is in that module's docstring.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Callable, Mapping
from typing import Any

from .features import DEFAULT_FEATURES
from .map_geometry import PAPER_GEOMETRY
from .memory_config import memory_table_from_v1
from .mlp import MAX_MEMBERS

CONTROLLER_SCHEMA = 8
"""Schema every controller file is written in (older ones are migrated on reading)."""
MAX_ABS_WEIGHT = 1e6
"""Largest weight magnitude accepted: beyond it every sigmoid is saturated (a road value is at
most 1 and a layer has at most 40 inputs), so larger values only come from a damaged file."""
_KEYS_V2 = (
    "format",
    "schema_version",
    "policy_kind",
    "layer_sizes",
    "bias",
    "weights",
    "road_library",
    "learner",
    "learner_config",
    "seed",
    "fitness_history",
    "learn",
    "checksum",
)
_KEYS_V1 = (
    "format",
    "schema_version",
    "layer_sizes",
    "bias",
    "weights",
    "road_library",
    "ga_config",
    "seed",
    "fitness_history",
    "learn",
)
#: The keys of a controller file of each schema (exactly these).
SCHEMA_KEYS: dict[int, tuple[str, ...]] = {
    1: _KEYS_V1,
    2: _KEYS_V2,
    3: (*_KEYS_V2[:-1], "memory", "checksum"),
    4: (*_KEYS_V2[:-1], "features", "memory", "checksum"),
    5: (*_KEYS_V2[:-1], "features", "memory", "checksum"),
    6: (*_KEYS_V2[:-1], "features", "memory", "frame_size", "checksum"),
    7: (*_KEYS_V2[:-1], "features", "memory", "frame_size", "map_geometry", "checksum"),
    8: (*_KEYS_V2[:-1], "features", "memory", "frame_size", "map_geometry", "checksum"),
}


def _from_schema1(data: dict[str, Any]) -> dict[str, Any]:
    """Schema 1 -> 2: the first release's GA settings become the learner's."""
    out = {k: v for k, v in data.items() if k != "ga_config"}
    out.update(policy_kind="mlp-sigmoid", learner="ga", learner_config=data["ga_config"])
    return out


def _from_schema2(data: dict[str, Any]) -> dict[str, Any]:
    """Schema 2 -> 3: a controller without memory stores null as its memory."""
    return {**data, "memory": None}


def _from_schema3(data: dict[str, Any]) -> dict[str, Any]:
    """Schema 3 -> 4: the network reads the road values (named)."""
    return {**data, "features": DEFAULT_FEATURES}


def _from_schema4(data: dict[str, Any]) -> dict[str, Any]:
    """Schema 4 -> 5: the memory table with every setting (options left out meant off)."""
    memory = data["memory"]
    return {**data, "memory": None if memory is None else memory_table_from_v1(memory)}


def _from_schema5(data: dict[str, Any]) -> dict[str, Any]:
    """Schema 5 -> 6: the frames it learned on were the paper's 640 x 480 (the only size then)."""
    return {**data, "frame_size": [640, 480]}


def _from_schema6(data: dict[str, Any]) -> dict[str, Any]:
    """Schema 6 -> 7: a ``fresh_felt`` map had the paper's constants (the paper preset's camera,
    0.10 m per forward command, 22.9 deg per pivot): its memory table gains ``geometry =
    "paper"`` and the file ``map_geometry`` those constants (null without that map)."""
    memory = data["memory"]
    if not isinstance(memory, dict) or memory.get("kind") != "fresh_felt":
        return {**data, "map_geometry": None}
    return {
        **data,
        "memory": memory_table_from_v1(memory),
        "map_geometry": PAPER_GEOMETRY.to_dict(),
    }


def _from_schema7(data: dict[str, Any]) -> dict[str, Any]:
    """Schema 7 -> 8: the same keys; a file before schema 8 holds one network (schema 8's
    ``weights`` may hold an ensemble's; :func:`migrate` refuses an older file that does)."""
    return dict(data)


#: One migration per schema step: ``MIGRATIONS[k]`` turns the contents of a schema-k file into
#: those of a schema k + 1 file meaning the same controller.
MIGRATIONS: dict[int, Callable[[dict[str, Any]], dict[str, Any]]] = {
    1: _from_schema1,
    2: _from_schema2,
    3: _from_schema3,
    4: _from_schema4,
    5: _from_schema5,
    6: _from_schema6,
    7: _from_schema7,
}


def migrate(data: dict[str, Any]) -> dict[str, Any]:
    """The contents of a controller file of any schema this build reads, as schema
    :data:`CONTROLLER_SCHEMA` (its keys checked, the checksum of schema 2 on verified first)."""
    version = data.get("schema_version")
    if isinstance(version, bool) or version not in SCHEMA_KEYS:
        raise ValueError(
            f"schema version {version!r} is not supported"
            f" (this version of lfd-track reads {', '.join(map(str, SCHEMA_KEYS))})"
        )
    keys = SCHEMA_KEYS[version]
    for key in keys:
        if key not in data:
            raise ValueError(f"missing key '{key}'")
    unknown = sorted(set(data) - set(keys))
    if unknown:
        raise ValueError(f"unknown key '{unknown[0]}'")
    if version >= 2:
        stored = data["checksum"]
        if not isinstance(stored, str) or stored != checksum(data):
            raise ValueError(
                "checksum mismatch: the file was changed or damaged after it was saved"
            )
    if version == 3 and data["memory"] is None:
        raise ValueError("a schema 3 controller must name its memory kind")
    weights = data["weights"]
    if version < 8 and isinstance(weights, list) and any(isinstance(w, list) for w in weights):
        raise ValueError(
            f"a schema {version} controller holds one network (an ensemble needs schema 8)"
        )
    while version < CONTROLLER_SCHEMA:
        data = MIGRATIONS[version](data)
        version += 1
    return {**data, "schema_version": version}


def checksum(contents: Mapping[str, Any]) -> str:
    """SHA-256 hex of the canonical JSON of every key of ``contents`` except ``checksum``."""
    body = {k: v for k, v in contents.items() if k != "checksum"}
    text = json.dumps(body, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def file_networks(weights: Any, kind: str, size: int, layout: str) -> list[list[Any]]:
    """The networks a (migrated) file's ``weights`` holds: one list of ``size`` finite numbers
    within :data:`MAX_ABS_WEIGHT`, or for an ensemble 2..:data:`MAX_MEMBERS` such lists (not
    for an Elman network, ``kind`` ``"elman-sigmoid"``); ``ValueError`` naming ``layout`` (the
    layer sizes and biases the file states) otherwise."""
    nested = isinstance(weights, list) and weights and all(isinstance(w, list) for w in weights)
    networks = weights if nested else [weights]
    if len(networks) > 1 and kind == "elman-sigmoid":
        raise ValueError("an Elman network is one network, not an ensemble")
    if not 1 <= len(networks) <= MAX_MEMBERS:
        raise ValueError(f"'weights' must hold 1..{MAX_MEMBERS} networks, got {len(networks)}")
    for index, net in enumerate(networks):
        which = "" if len(networks) == 1 else f" (network {index + 1} of {len(networks)})"
        if not isinstance(net, list) or not all(is_finite_number(w) for w in net):
            raise ValueError(
                "'weights' must be a list of finite numbers (or, for an ensemble, a list of such"
                " lists)"
            )
        if len(net) != size:
            raise ValueError(f"expected {size} weights for {layout}, got {len(net)}{which}")
        if any(abs(w) > MAX_ABS_WEIGHT for w in net):
            raise ValueError(f"'weights' must lie within +-{MAX_ABS_WEIGHT:g}")
    return networks


def check_ga_config(config: dict[str, Any], bias: bool) -> None:
    """Plausibility of a GA's settings without importing the GA (a policy never imports its
    trainer): known keys, numbers where numbers belong, and the same ``bias`` as the weights."""
    counts = ("population_size", "generations", "tournament_size", "elitism")
    rates = ("mutation_rate", "mutation_delta", "init_range", "threshold")
    unknown = sorted(set(config) - {*counts, *rates, "bias"})
    if unknown:
        raise ValueError(f"unknown GA config key '{unknown[0]}'")
    for name in counts:
        value = config.get(name, 0)
        if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= 10**9:
            raise ValueError(f"GA config {name} must be an integer in 0..1e9, got {value!r}")
    for name in rates:
        value = config.get(name, 0.0)
        if not is_finite_number(value) or value < 0:
            raise ValueError(f"GA config {name} must be a non-negative number, got {value!r}")
    if not config.get("mutation_rate", 0.0) <= 1.0:
        raise ValueError("GA config mutation_rate must be in [0, 1]")
    if "bias" in config and config["bias"] != bias:
        raise ValueError("'bias' disagrees with the GA config's bias")


def is_finite_number(value: Any) -> bool:
    """Whether ``value`` is a JSON number (int or float, not bool) with a finite float value."""
    if not isinstance(value, (int, float)) or isinstance(value, bool):
        return False
    try:
        return math.isfinite(float(value))
    except OverflowError:  # an integer too large for a float
        return False
