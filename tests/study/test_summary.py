"""Pooling job results: unseen tracks, corner failures, human effort, and the picture."""

from __future__ import annotations

import numpy as np
import pytest
from study_helpers import TINY_STUDY, write_study

from lfd_track.study.spec import load_study
from lfd_track.study.stats import controller_interval
from lfd_track.study.summary import (
    build_study_results,
    human_commands,
    study_markdown,
    study_plot,
)


def outcome(track, success, negotiated, order=("1", "2", "3", "4"), failure="reversed"):
    return {
        "track": track,
        "direction": "direction_1" if track == "training" else "ccw",
        "corner_order": list(order),
        "corners_reached": list(negotiated),
        "corners_negotiated": list(negotiated),
        "failure": None if success else failure,
        "success": success,
        "repetition": 0,
        "trial": 0,
        "steps": 10,
    }


def job_results(outcomes, cases=(150,), wall=5.0):
    return {
        "config": {"human": {"library_only_commands": 10}},
        "demonstrations": [{"cases": c} for c in cases],
        "outcomes": outcomes,
        "training_accuracy": [0.9],
        "timing_s": {"wall": wall},
    }


@pytest.fixture
def study(tmp_path):
    return load_study(write_study(tmp_path, TINY_STUDY))


def test_unseen_tracks_are_scored_one_by_one_and_pooled(study):
    seed0, seed1 = study.jobs()
    a = job_results(
        [
            outcome("testing", True, ["1", "2", "3", "4"]),
            outcome("testing", False, ["1", "2", "3"]),  # charged to corner 4
            outcome("unseen_a", True, ["a", "b"], order=("a", "b")),
            outcome("unseen_b", False, [], order=("x", "y"), failure="timeout"),
        ]
    )
    b = job_results(
        [
            outcome("testing", False, ["1", "2", "3"]),
            outcome("training", True, ["1", "2"], order=("1", "2")),
            outcome("unseen_a", False, ["a"], order=("a", "b")),
        ],
        cases=(140,),
        wall=7.0,
    )
    summary = build_study_results(study, [(seed0, a), (seed1, b)])
    (c,) = summary["conditions"]
    assert (c["testing"]["successes"], c["testing"]["trials"]) == (1, 3)
    assert (c["training"]["successes"], c["training"]["trials"]) == (1, 1)
    assert set(c["unseen_tracks"]) == {"unseen_a", "unseen_b"}
    assert (
        c["unseen_tracks"]["unseen_a"]["successes"],
        c["unseen_tracks"]["unseen_a"]["trials"],
    ) == (1, 2)
    assert (c["unseen"]["successes"], c["unseen"]["trials"]) == (1, 3)
    assert c["corner_failures"]["testing"] == {"1": 0, "2": 0, "3": 0, "4": 2}
    assert c["corner_failures"]["unseen_a"] == {"a": 0, "b": 1}
    assert c["failure_kinds"]["unseen_b"] == {"timeout": 1}
    # Human commands: every demonstration command (recorded cases + 10 library-only ones).
    assert c["human_commands"]["total"] == (150 + 10) + (140 + 10)
    assert c["human_commands"]["per_repetition"] == pytest.approx(310 / 2)
    assert c["wall_s"] == 12.0 and [s["seed"] for s in c["per_seed"]] == [0, 1]
    table = study_markdown(summary)
    assert "Unseen tracks one by one" in table and "| unseen_a | unseen_b |" in table
    assert "1/3 = 33 %" in table


def test_human_effort_reported_by_a_method_is_used_as_is():
    base = job_results([], cases=(150,))
    assert human_commands(base) == 160
    assert human_commands({**base, "human_effort": {"total": {"commands": 321}}}) == 321


def test_corrections_and_takeovers_are_pooled_per_repetition(study):
    seed0, seed1 = study.jobs()
    effort = {"commands": 200, "corrections": 4, "takeovers": 6, "learning_drive_s": 70.0}
    a = {**job_results([], cases=(150,)), "human_effort": {"total": effort}}
    b = job_results([], cases=(150,))  # reports no effort: 0 corrections, 0 takeovers
    (c,) = build_study_results(study, [(seed0, a), (seed1, b)])["conditions"]
    assert c["human_effort"]["corrections"] == {"total": 4.0, "per_repetition": 2.0}
    assert c["human_effort"]["takeovers"]["per_repetition"] == 3.0
    assert c["human_effort"]["learning_drive_s"]["total"] == 70.0
    assert c["human_effort"]["autonomous_drive_s"]["total"] == 0.0
    assert c["human_commands"]["total"] == 200 + 160


def test_the_picture_draws_each_rate_with_its_interval_bar(study):
    seed0, seed1 = study.jobs()
    wins = [outcome("training", True, ["1", "2"], order=("1", "2"))] * 3
    losses = [outcome("training", False, [], order=("1", "2"))] * 7
    summary = build_study_results(study, [(seed0, job_results(wins)), (seed1, job_results(losses))])
    (c,) = summary["conditions"]
    low, high = c["training"]["ci95"]
    img = study_plot(summary)
    green = np.all(img == (44, 160, 44), axis=2)
    rows = np.flatnonzero(green[60:, :].any(axis=1)) + 60  # below the legend
    top, bottom = 60, img.shape[0] - 70
    plot_h = bottom - top
    assert rows.min() == pytest.approx(top + plot_h * (1 - high), abs=3)
    assert rows.max() == pytest.approx(top + plot_h * (1 - low), abs=3)


def test_rates_also_carry_an_interval_that_resamples_learned_controllers(study):
    seed0, seed1 = study.jobs()
    lap = outcome("testing", True, ["1", "2", "3", "4"])
    miss = outcome("testing", False, ["1", "2", "3"])
    # Seed 0: repetition 0 laps 4 of 4, repetition 1 none; seed 1: repetition 0 laps 2 of 4.
    a = job_results(
        [{**lap, "repetition": 0}] * 4 + [{**miss, "repetition": 1}] * 4,
    )
    b = job_results([lap, lap, miss, miss])
    summary = build_study_results(study, [(seed0, a), (seed1, b)])
    (c,) = summary["conditions"]
    assert (c["testing"]["successes"], c["testing"]["trials"]) == (6, 12)
    # Three controllers (seed x repetition) with rates 1, 0 and 0.5, resampled whole.
    assert c["testing"]["ci95_controllers"] == controller_interval([(4, 4), (0, 4), (2, 4)])
    low, high = c["testing"]["ci95_controllers"]
    w_low, w_high = c["testing"]["ci95"]
    assert low < w_low and high > w_high
    assert c["training"]["ci95_controllers"] is None  # no training trials here
    table = study_markdown(summary)
    assert "resample whole learned controllers" in table
    assert f"| paper | – | 50 % [{100 * low:.0f}–{100 * high:.0f}] | – |" in table


def test_the_summary_names_its_environment_and_each_distinct_one_of_its_jobs(study):
    from lfd_track.utils.provenance import environment

    seed0, seed1 = study.jobs()
    old = job_results([outcome("testing", True, ["1", "2", "3", "4"])])  # written before: none
    here = dict(old, environment=environment())
    other = dict(old, environment=dict(environment(), numpy="0.0"))
    summary = build_study_results(study, [(seed0, old), (seed1, here)])
    assert summary["environment"] == environment()
    assert summary["job_environments"] == [environment()]
    summary = build_study_results(study, [(seed0, here), (seed1, other), (seed1, here)])
    assert sorted(e["numpy"] for e in summary["job_environments"]) == sorted(
        ["0.0", environment()["numpy"]]
    )
    assert build_study_results(study, [(seed0, old)])["job_environments"] == []
