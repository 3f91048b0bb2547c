"""Procedural loops in a benchmark run: which loops a repetition laps, the teacher's check that
admits a loop to the score, and the results by the loop's sharpest turn and strip width.

The rule of the benchmark (``tracks/README.md``, "Procedural loops"): settings and rounds are
chosen on ``train`` and ``validation`` loops only; a configuration is scored on the ``test`` split
once, after it is frozen. ``BenchmarkConfig.random_loops`` loops of ``random_split`` are drawn per
repetition, from the repetition's own stream (:func:`draw_loop`), so every condition of a study
with the same seed laps the same loops in the same worlds.

**The teacher's check, written before any loop was scored.** A drawn loop enters the score only
if the scripted human with its default traits (:class:`~lfd_track.teaching.scripted.HumanConfig`,
pure pursuit on the centreline, reaction delays and lapses on) laps it in both directions, each
in the very world the controller's lap of that direction is driven in. A loop the teacher cannot
lap says nothing of what was learned; it is recorded as excluded (with the teacher's outcome per
direction), its place taken by the next loop drawn, and its share reported beside every rate.
Each admitted loop is lapped once each way: the sample is the distribution of loops, not the
repeat of one (``trials_per_direction`` applies to the named test tracks only).
"""

from __future__ import annotations

from collections.abc import Collection, Iterable, Iterator, Mapping, Sequence
from typing import Any

import numpy as np

from ..envs.track_env import LfDTrackEnv
from ..teaching.scripted import HumanConfig, ScriptedHuman
from ..world.driver import CentrelineDriver
from ..world.loops import (
    LOOPS_PER_SPLIT,
    TURN_BIN_LABELS,
    WIDTH_BIN_LABELS,
    is_loop_name,
    loop_name,
    parse_loop_name,
    sharpest_turn_deg,
    turn_bin,
    width_bin,
)
from ..world.track import loop_track

LOOP_STREAM = 0x6C6F6F70
"""Mixed into a repetition's trial seed to draw its loops (a stream of its own: the named tracks'
worlds do not move when ``random_loops`` changes)."""
TEACHER = HumanConfig()
"""The human of the teacher's check: the default scripted human, whatever the run's human is, so
every condition of a study excludes the same loops."""
MAX_DRAWS_PER_LOOP = 20
"""Give up (one line) when this many loops per admitted loop were drawn: a distribution the
teacher cannot lap is no benchmark."""


def loop_draws(trial_seed: int, split: str) -> Iterator[tuple[str, tuple[int, int]]]:
    """Distinct loops of ``split`` in the order a repetition draws them: (name, (ccw world seed,
    cw world seed))."""
    rng = np.random.default_rng(np.random.SeedSequence([int(trial_seed), LOOP_STREAM]))
    seen: set[int] = set()
    while len(seen) < LOOPS_PER_SPLIT:
        index = int(rng.integers(0, LOOPS_PER_SPLIT))
        worlds = (int(rng.integers(0, 2**62)), int(rng.integers(0, 2**62)))
        if index in seen:
            continue
        seen.add(index)
        yield loop_name(split, index), worlds


def merged_record(records: Iterable[tuple[int, Mapping[str, Any]]]) -> dict[str, Any] | None:
    """One run's draw record from its repetitions' ``(index, record)`` pairs (the records
    :func:`~lfd_track.benchmark.runner.run_loop_trials` returns): loops drawn, summed, and every
    excluded loop tagged with its repetition; None when no repetition drew any."""
    drew = [(index, record) for index, record in records if record]
    if not drew:
        return None
    return {
        "drawn": sum(int(record["drawn"]) for _, record in drew),
        "excluded": [
            dict(e, repetition=index) for index, record in drew for e in record.get("excluded", [])
        ],
    }


def teacher_lap(env: LfDTrackEnv, world_seed: int) -> dict[str, Any]:
    """One lap of the teacher (:data:`TEACHER`) on ``env`` in the world ``world_seed`` draws:
    ``{"success", "failure", "steps"}``. The env keeps that world, so a lap reset with the same
    seed afterwards drives the very floor the teacher drove."""
    _, info = env.reset(seed=world_seed)
    driver = CentrelineDriver(env.track, TEACHER.driver)
    person = ScriptedHuman(TEACHER, np.random.default_rng(world_seed))
    steps = 0
    while True:
        command = person.decide(driver, np.asarray(info["pose"]), info["progress_m"])
        _, _, terminated, truncated, info = env.step(int(command))
        steps += 1
        if terminated or truncated:
            break
    failure = info["failure"]
    if not info["success"] and failure is None:
        failure = "timeout"
    return {"success": bool(info["success"]), "failure": failure, "steps": steps}


def _bin_rows(
    outcomes: Sequence[Any], key: Any, labels: Sequence[str]
) -> dict[str, dict[str, int]]:
    rows = {label: {"laps": 0, "successes": 0, "loops": 0} for label in labels}
    loops_in: dict[str, set[str]] = {label: set() for label in labels}
    for o in outcomes:
        label = key(o.track)
        rows[label]["laps"] += 1
        rows[label]["successes"] += int(o.success)
        loops_in[label].add(o.track)
    for label in labels:
        rows[label]["loops"] = len(loops_in[label])
    return rows


def loop_facts(name: str) -> tuple[float, float]:
    """(sharpest turn [deg], strip width [m]) of the procedural loop ``name``."""
    split, index = parse_loop_name(name)
    track = loop_track(split, index)
    return sharpest_turn_deg(track), track.width_m


def random_loop_results(
    outcomes: Sequence[Any], record: Mapping[str, Any] | None = None
) -> dict[str, Any]:
    """The ``random_loops`` section of results.json from the trial outcomes on procedural loops
    (and the repetitions' draw ``record``: drawn and excluded loops): laps and successes pooled,
    per direction, by sharpest-turn bin and by strip-width bin, and the teacher's exclusions."""
    outcomes = [o for o in outcomes if is_drawn_loop(o.track)]
    facts = {name: loop_facts(name) for name in sorted({o.track for o in outcomes})}
    section: dict[str, Any] = {
        "loops": len(facts),
        "laps": len(outcomes),
        "successes": sum(int(o.success) for o in outcomes),
    }
    for direction in ("ccw", "cw"):
        mine = [o for o in outcomes if o.direction == direction]
        section[direction] = {"laps": len(mine), "successes": sum(int(o.success) for o in mine)}
    section["by_sharpest_turn"] = _bin_rows(
        outcomes, lambda t: turn_bin(facts[t][0]), TURN_BIN_LABELS
    )
    section["by_width"] = _bin_rows(outcomes, lambda t: width_bin(facts[t][1]), WIDTH_BIN_LABELS)
    if record is not None:
        section["drawn"] = int(record.get("drawn", 0))
        section["excluded"] = list(record.get("excluded", []))
    return section


def is_drawn_loop(track: str, test_tracks: Collection[str] = ()) -> bool:
    """Whether ``track`` is a procedural loop a repetition drew: a ``random:<split>:<index>``
    name not among the run's named ``test_tracks`` (those are scored as tracks)."""
    return track not in test_tracks and is_loop_name(track)
