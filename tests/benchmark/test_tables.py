"""Corner-success counting, the paper's numbers, tables, report and results.json."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from lfd_track.benchmark import (
    TrialOutcome,
    build_results,
    format_tables,
    paper_results,
    results_json_text,
    write_report,
    write_results_json,
)
from lfd_track.benchmark.paper import CORNER_ORDER, DIRECTIONS, TRACK_RESULT_KEYS
from lfd_track.benchmark.schema import RESULTS_SCHEMA

CW = ("3", "2", "1", "4")


def _trial(track, direction, reached, negotiated, failure, *, rep=0, trial=0, order=None):
    order = order or CORNER_ORDER[direction]
    return TrialOutcome(
        track=track,
        direction=direction,
        corner_order=order,
        corners_reached=tuple(reached),
        corners_negotiated=tuple(negotiated),
        failure=failure,
        success=failure is None,
        repetition=rep,
        trial=trial,
        steps=100 + trial,
    )


def _scripted() -> list[TrialOutcome]:
    return [
        # Clockwise laps.
        _trial("testing", "cw", CW, CW, None, trial=0),  # success
        _trial("testing", "cw", "32", "3", "reversed", trial=1),  # fails at corner 2
        # Leaves the felt on the straight after corner 3, before reaching corner 2: charged to 2.
        _trial("testing", "cw", "3", "3", "off_track", trial=2),
        _trial("testing", "cw", "", "", "timeout", rep=1, trial=0),  # never reaches corner 3
        _trial("testing", "cw", CW, "321", "off_track", rep=1, trial=1),  # fails at corner 4
        # Training track, direction 1: a success, and a failure after the last corner.
        _trial("training", "direction_1", "12", "12", None, trial=0),
        _trial("training", "direction_1", "12", "12", "reversed", trial=1),
        _trial("training", "direction_1", "1", "", "reversed", trial=2),
        # Counter-clockwise: one success.
        _trial("testing", "ccw", "1234", "1234", None, trial=0),
    ]


def _corner(reached, failures, physical, reversed_=0, off_track=0, timeout=0):
    return {
        "reached": reached,
        "failures": failures,
        "physically_reached": physical,
        "failure_kinds": {"reversed": reversed_, "off_track": off_track, "timeout": timeout},
    }


def test_scripted_outcomes_give_the_expected_tables() -> None:
    results = build_results(_scripted(), repetitions=2, seed=7, timing_s={"total": 1.5})
    assert (
        results["schema"] == RESULTS_SCHEMA == 13
        and results["repetitions"] == 2
        and results["seed"] == 7
    )
    assert results["testing_track"]["cw"] == {
        "laps": 5,
        "successes": 1,
        "success_rate": 0.2,
        "corner_order": ["3", "2", "1", "4"],
        "corners": {
            "3": _corner(5, 1, 4, timeout=1),
            "2": _corner(4, 2, 3, reversed_=1, off_track=1),
            "1": _corner(2, 0, 2),
            "4": _corner(2, 1, 2, off_track=1),
        },
        "failures_after_last_corner": 0,
        "failure_kinds": {"reversed": 1, "off_track": 2, "timeout": 1},
    }
    assert list(results["testing_track"]["cw"]["corners"]) == ["3", "2", "1", "4"]
    ccw = results["testing_track"]["ccw"]
    assert ccw["laps"] == 1 and ccw["successes"] == 1
    assert [c["reached"] for c in ccw["corners"].values()] == [1, 1, 1, 1]
    testing = results["testing_track"]
    assert (testing["laps"], testing["successes"], testing["success_rate"]) == (6, 2, 0.333333)

    d1 = results["training_track"]["direction_1"]
    assert d1["trials"] == 3 and d1["successes"] == 1
    assert d1["corners"] == {"1": _corner(3, 1, 3, reversed_=1), "2": _corner(2, 0, 2)}
    assert d1["failures_after_last_corner"] == 1
    d2 = results["training_track"]["direction_2"]  # no trials: zero counts, paper's order
    assert d2["trials"] == 0 and d2["success_rate"] is None
    assert list(d2["corners"]) == ["2", "1"]
    assert all(c["reached"] == 0 for c in d2["corners"].values())

    assert results["paper"] == paper_results()
    assert results["timing_s"] == {"total": 1.5}
    assert [TrialOutcome.from_dict(d) for d in results["outcomes"]] == _scripted()


def _random_outcomes(rng: np.random.Generator, n: int) -> list[TrialOutcome]:
    outcomes = []
    for i in range(n):
        track = ("training", "testing")[int(rng.integers(2))]
        direction = DIRECTIONS[track][int(rng.integers(2))]
        order = CORNER_ORDER[direction]
        negotiated = int(rng.integers(0, len(order) + 1))
        reached = min(len(order), negotiated + int(rng.integers(0, 2)))
        if negotiated == len(order) and rng.random() < 0.7:
            failure = None
        else:
            failure = ("reversed", "off_track", "timeout")[int(rng.integers(3))]
        outcomes.append(
            _trial(track, direction, order[:reached], order[:negotiated], failure, trial=i)
        )
    return outcomes


@pytest.mark.parametrize("seed", range(5))
def test_progressive_identities_hold(seed: int) -> None:
    results = build_results(
        _random_outcomes(np.random.default_rng(seed), 80), repetitions=1, seed=seed, timing_s={}
    )
    for track, track_key in TRACK_RESULT_KEYS.items():
        for direction in DIRECTIONS[track]:
            d = results[track_key][direction]
            n = d["trials" if track == "training" else "laps"]
            corners = [d["corners"][label] for label in d["corner_order"]]
            assert corners[0]["reached"] == n
            for this, nxt in zip(corners, corners[1:], strict=False):
                assert nxt["reached"] == this["reached"] - this["failures"]
            for c in corners:
                assert c["physically_reached"] <= c["reached"]
                assert sum(c["failure_kinds"].values()) == c["failures"]
            failures = sum(c["failures"] for c in corners)
            assert d["successes"] == n - failures - d["failures_after_last_corner"]


def test_paper_numbers_are_the_papers_and_self_consistent() -> None:
    paper = paper_results()
    training, testing = paper["training_track"], paper["testing_track"]

    def rows(d):
        return [
            (label, d["corners"][label]["reached"], d["corners"][label]["failures"])
            for label in d["corner_order"]
        ]

    assert rows(training["direction_1"]) == [("1", 30, 1), ("2", 29, 0)]
    assert rows(training["direction_2"]) == [("2", 30, 2), ("1", 28, 0)]
    assert rows(testing["cw"]) == [("3", 30, 0), ("2", 30, 7), ("1", 23, 4), ("4", 19, 5)]
    assert rows(testing["ccw"]) == [("1", 30, 3), ("2", 27, 7), ("3", 20, 0), ("4", 20, 6)]
    for track, track_key in TRACK_RESULT_KEYS.items():
        count_key = "trials" if track == "training" else "laps"
        for direction in DIRECTIONS[track]:
            d = paper[track_key][direction]
            r = rows(d)
            assert d[count_key] == 30
            assert d["successes"] == d[count_key] - sum(f for _, _, f in r)
            for (_, reached, failures), (_, next_reached, _) in zip(r, r[1:], strict=False):
                assert next_reached == reached - failures
            assert list(d["corners"]) == list(CORNER_ORDER[direction])
    assert (training["successes"], training["trials"], training["success_rate"]) == (57, 60, 0.95)
    assert (testing["successes"], testing["laps"]) == (28, 60)
    assert testing["cw"]["successes"] == testing["ccw"]["successes"] == 14
    paper["training_track"]["success_rate"] = 0.0  # a fresh copy each call
    assert paper_results()["training_track"]["success_rate"] == 0.95


def test_results_json_is_byte_identical_and_keeps_corner_order(tmp_path: Path) -> None:
    timing = {"evolve": np.float64(12.3456789123), "total": 20.000000001, "workers": np.int64(2)}
    a = write_results_json(
        tmp_path / "a.json", build_results(_scripted(), repetitions=2, seed=7, timing_s=timing)
    )
    b = write_results_json(
        tmp_path / "sub" / "b.json",
        build_results(_scripted(), repetitions=2, seed=7, timing_s=dict(timing)),
    )
    assert a.read_bytes() == b.read_bytes()
    text = a.read_text()
    assert text.endswith("}\n")
    loaded = json.loads(text)
    assert loaded["timing_s"] == {"evolve": 12.345679, "total": 20.0, "workers": 2}
    assert loaded["testing_track"]["cw"]["corner_order"] == ["3", "2", "1", "4"]
    assert text == results_json_text(loaded)  # a loaded file rewrites to the same bytes
    assert text == json.dumps(loaded, sort_keys=True, indent=2) + "\n"  # keys sorted
    # Different inputs give different bytes.
    other = build_results(_scripted()[:-1], repetitions=2, seed=7, timing_s=timing)
    assert results_json_text(other) != text
    with pytest.raises(TypeError):
        results_json_text({"bad": object()})
    assert json.loads(results_json_text({"nan": float("nan")})) == {"nan": None}


def _table_cells(text: str, first_cell: str) -> dict[str, list[str]]:
    """Rows of the pipe table whose header starts with ``first_cell``: row title -> cells."""
    lines = text.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith(f"| {first_cell} "))
    table = {}
    for line in [lines[start], *lines[start + 2 :]]:
        if not line.startswith("|"):
            break
        cells = [c.strip() for c in line.strip("|").split("|")]
        table[cells[0]] = cells[1:]
    return table


def test_format_tables_puts_ours_beside_the_papers() -> None:
    text = format_tables(build_results(_scripted(), repetitions=2, seed=7, timing_s={}))
    cw = _table_cells(text, "Clockwise")
    assert cw["Clockwise"] == ["Corner 3", "Corner 2", "Corner 1", "Corner 4"]
    assert cw["Times reached"] == ["5 (30)", "4 (30)", "2 (23)", "2 (19)"]
    assert cw["Failures"] == ["1 (0)", "2 (7)", "0 (4)", "1 (5)"]
    assert cw["Physically reached"] == ["4", "3", "2", "2"]
    d2 = _table_cells(text, "Direction 2")
    assert d2["Direction 2"] == ["Corner 2", "Corner 1"]
    assert d2["Times reached"] == ["0 (30)", "0 (28)"]
    rates = _table_cells(text, "Track, direction")
    assert rates["Testing, all"] == ["2/6 = 33.3 %", "28/60 = 46.7 %"]
    assert rates["Training, all"] == ["1/3 = 33.3 %", "57/60 = 95.0 %"]
    assert rates["Training, direction 2"][0] == "n/a"
    assert "5 of the 21" in text  # the caption discrepancy footnote
    # The same tables come out of a results.json read back (corner order from the file).
    loaded = json.loads(
        results_json_text(build_results(_scripted(), repetitions=2, seed=7, timing_s={}))
    )
    assert format_tables(loaded) == text


def test_write_report_is_markdown_with_extra_sections(tmp_path: Path) -> None:
    results = build_results(_scripted(), repetitions=2, seed=7, timing_s={"total": 61.34})
    path = write_report(tmp_path / "out", results, extra_sections=["## Plots\n\n![t](t.png)\n"])
    text = path.read_text()
    assert path.name == "report.md" and text.startswith("# Corner-success benchmark\n")
    assert format_tables(results).strip() in text
    assert _table_cells(text, "Stage")["total"] == ["61.3 s"]
    assert text.rstrip().endswith("![t](t.png)")
    assert list((tmp_path / "out").iterdir()) == [path]  # no temporary files left behind


def test_inconsistent_outcomes_are_rejected() -> None:
    with pytest.raises(ValueError, match="no failure"):
        TrialOutcome("testing", "cw", CW, CW, CW, "reversed", True, 0, 0, 1)
    with pytest.raises(ValueError, match="no failure"):
        TrialOutcome("testing", "cw", CW, "3", "3", None, False, 0, 0, 1)
    with pytest.raises(ValueError, match="every corner"):
        TrialOutcome("testing", "cw", CW, "321", "321", None, True, 0, 0, 1)
    with pytest.raises(ValueError, match="prefix"):
        TrialOutcome("testing", "cw", CW, "2", "", "timeout", False, 0, 0, 1)
    with pytest.raises(ValueError, match="never reached"):
        TrialOutcome("testing", "cw", CW, "3", "32", "timeout", False, 0, 0, 1)
    with pytest.raises(ValueError, match="direction"):
        TrialOutcome("testing", "direction_1", CW, "", "", "timeout", False, 0, 0, 1)
    with pytest.raises(ValueError, match="failure must be"):
        TrialOutcome("testing", "cw", CW, "", "", "crashed", False, 0, 0, 1)
    one = _trial("testing", "cw", "", "", "timeout")
    with pytest.raises(ValueError, match="duplicate"):
        build_results([one, one], repetitions=1, seed=0, timing_s={})
    other_order = _trial("testing", "cw", "", "", "timeout", trial=1, order=("1", "2", "3", "4"))
    with pytest.raises(ValueError, match="corner order"):
        build_results([one, other_order], repetitions=1, seed=0, timing_s={})


def test_trajectory_is_kept_out_of_equality_and_json() -> None:
    plain = _trial("testing", "cw", CW, CW, None)
    with_path = TrialOutcome(**{**plain.to_dict(), "trajectory": np.zeros((5, 3))})
    assert with_path == plain and "trajectory" not in with_path.to_dict()
    assert with_path.charged_corner is None
    assert _trial("testing", "cw", "32", "3", "reversed").charged_corner == "2"


def _int(cell: str) -> int:
    """Our count of an ``ours (paper)`` cell."""
    return int(cell.split(" (")[0])


@pytest.mark.parametrize("seed", range(3))
def test_table_rows_add_up_to_the_successes(seed: int) -> None:
    # Trials failing after the last corner (training track) have their own row, so the printed
    # counts add up: first corner reached - failures - failures after it = successes.
    outcomes = _random_outcomes(np.random.default_rng(seed), 80) + _scripted()
    for i, t in enumerate(outcomes):
        object.__setattr__(t, "trial", i)
    results = build_results(outcomes, repetitions=1, seed=seed, timing_s={})
    text = format_tables(results)
    for title in ("Direction 1", "Direction 2", "Clockwise", "Counter-clockwise"):
        rows = _table_cells(text, title)
        after = rows.get("Failures after the last corner", ["", "0 (–)"])[-1]
        if title.startswith("Direction"):
            assert "Failures after the last corner" in rows
        successes = _int(rows["Successes"][-1])
        assert (
            _int(rows["Times reached"][0]) - sum(map(_int, rows["Failures"])) - _int(after)
            == successes
        )
    d1 = _table_cells(
        format_tables(build_results(_scripted(), repetitions=1, seed=0, timing_s={})), "Direction 1"
    )
    assert d1["Failures after the last corner"] == ["", "1 (–)"]
    assert d1["Successes"] == ["", "1 (29)"]
    cw = _table_cells(
        format_tables(build_results(_scripted(), repetitions=1, seed=0, timing_s={})), "Clockwise"
    )
    assert "Failures after the last corner" not in cw  # the loop's finish is its last corner


def test_timing_table_is_in_words_and_seconds(tmp_path: Path) -> None:
    timing = {
        "wall": 75.1,
        "workers": 2,
        "demonstration_sum": 17.8,
        "evolution_sum": 3.1,
        "trials_sum": 121.3,
    }
    results = build_results(_scripted(), repetitions=2, seed=7, timing_s=timing)
    text = write_report(tmp_path, results).read_text()
    rows = _table_cells(text, "Stage")
    assert rows == {
        "Stage": ["Time"],
        "Whole benchmark (wall clock)": ["75.1 s"],
        "Recording the demonstrations": ["17.8 s"],
        "Evolving the controllers": ["3.1 s"],
        "Driving the autonomous trials": ["121.3 s"],
    }
    assert "Run on 2 worker processes." in text
    assert "_sum" not in text


def test_results_json_keeps_small_settings_loadable():
    """Six decimals would store BC's epsilon (1e-8) as 0, which BCConfig refuses to load."""
    from lfd_track.benchmark.runner import BenchmarkConfig, config_dict
    from lfd_track.learning.bc import BCConfig

    data = json.loads(results_json_text({"config": config_dict(BenchmarkConfig()), "x": 0.1234567}))
    assert data["config"]["bc"]["epsilon"] == 1e-8
    assert BCConfig.from_dict(data["config"]["bc"]) == BCConfig()
    assert data["x"] == 0.123457  # ordinary values keep their six decimals
    assert json.loads(results_json_text({"tiny": 1.234567891e-7}))["tiny"] == 1.23457e-7
