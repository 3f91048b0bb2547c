"""A study pools its conditions' procedural-loop laps: the rate with its intervals, by the loop's
sharpest turn and by strip width, the teacher's exclusions, and a job missing a lap is refused."""

from __future__ import annotations

import pytest
from study_helpers import TINY_STUDY, write_study

from lfd_track.benchmark.loops import loop_facts
from lfd_track.study.spec import load_study
from lfd_track.study.summary import build_study_results, check_job_results, study_markdown
from lfd_track.world.loops import loop_name, turn_bin, width_bin

STUDY = TINY_STUDY.replace(
    "trials_per_direction = 1", 'trials_per_direction = 1\nrandom_loops = 2\nrandom_split = "test"'
)


def lap(track, direction, success, repetition=0):
    order = [str(i) for i in range(1, 4)]
    return {
        "track": track,
        "direction": direction,
        "corner_order": order,
        "corners_reached": order if success else order[:1],
        "corners_negotiated": order if success else order[:1],
        "failure": None if success else "off_track",
        "success": success,
        "repetition": repetition,
        "trial": 0,
        "steps": 10,
    }


def results(loops, successes, excluded=0):
    outcomes = [
        lap(name, direction, ok)
        for name, oks in zip(loops, successes, strict=True)
        for direction, ok in zip(("ccw", "cw"), oks, strict=True)
    ]
    return {
        "config": {"random_split": "test", "human": {"library_only_commands": 10}},
        "demonstrations": [{"cases": 150}],
        "outcomes": outcomes,
        "training_accuracy": [0.9],
        "timing_s": {"wall": 1.0},
        "random_loops": {"drawn": len(loops) + excluded, "excluded": [{}] * excluded},
    }


@pytest.fixture
def study(tmp_path):
    return load_study(write_study(tmp_path, STUDY))


def test_loops_are_pooled_by_sharpest_turn_and_width(study):
    seed0, seed1 = study.jobs()
    a_loops = [loop_name("test", 3), loop_name("test", 4)]
    b_loops = [loop_name("test", 5), loop_name("test", 6)]
    a = results(a_loops, [(True, True), (True, False)], excluded=1)
    b = results(b_loops, [(False, False), (True, True)])
    (c,) = build_study_results(study, [(seed0, a), (seed1, b)])["conditions"]
    loops = c["random_loops"]
    assert loops["split"] == "test" and loops["loops"] == 4
    assert (loops["laps"]["successes"], loops["laps"]["trials"]) == (5, 8)
    assert loops["laps"]["ci95"][0] < 5 / 8 < loops["laps"]["ci95"][1]
    assert "ci95_controllers" in loops["laps"]
    assert (loops["drawn"], loops["excluded"]) == (5, 1)
    expected_turn: dict[str, list[int]] = {}
    expected_width: dict[str, list[int]] = {}
    for name, oks in zip(a_loops + b_loops, [(1, 1), (1, 0), (0, 0), (1, 1)], strict=True):
        sharpest, width = loop_facts(name)
        for table, label in (
            (expected_turn, turn_bin(sharpest)),
            (expected_width, width_bin(width)),
        ):
            row = table.setdefault(label, [0, 0])
            row[0] += sum(oks)
            row[1] += 2
    for label, (k, n) in expected_turn.items():
        got = loops["by_sharpest_turn"][label]
        assert (got["successes"], got["trials"]) == (k, n)
    for label, (k, n) in expected_width.items():
        got = loops["by_width"][label]
        assert (got["successes"], got["trials"]) == (k, n)
    # Drawn loops are not "unseen tracks" one by one.
    assert c["unseen_tracks"] == {} and c["unseen"]["trials"] == 0
    table = study_markdown(build_study_results(study, [(seed0, a), (seed1, b)]))
    assert "Procedural loops" in table and "sharpest >135" in table
    assert "| paper | test | 4 | 5/8 = 62 %" in table
    assert "The same laps by strip width" in table


def test_a_job_missing_a_loop_lap_is_refused(study):
    full = results([loop_name("test", 3), loop_name("test", 4)], [(True, True), (True, False)])
    training = [
        dict(lap("training", d, True), corner_order=["1", "2"], corners_reached=["1", "2"])
        | {"corners_negotiated": ["1", "2"]}
        for d in ("direction_1", "direction_2")
    ]
    full["outcomes"] = training + full["outcomes"]
    check_job_results(full, 1, 1, (), random_loops=2)
    short = dict(full, outcomes=full["outcomes"][:-1])
    with pytest.raises(ValueError, match="holds 3 laps of procedural loops in repetition 0"):
        check_job_results(short, 1, 1, (), random_loops=2)
    twice = dict(full, outcomes=full["outcomes"] + full["outcomes"][-1:])
    with pytest.raises(ValueError, match="lapped once per repetition"):
        check_job_results(twice, 1, 1, (), random_loops=2)
