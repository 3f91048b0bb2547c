"""Procedural loops: every loop is a valid track file of the documented distribution, the same
seed gives the same vertices, and the splits never share a loop."""

from __future__ import annotations

import math

import numpy as np
import pytest

from lfd_track.errors import LfdTrackError
from lfd_track.world import loops
from lfd_track.world.loops import (
    DEFAULT_LOOPS,
    LOOPS_PER_SPLIT,
    SPLITS,
    TURN_BIN_LABELS,
    WIDTH_BIN_LABELS,
    LoopDistribution,
    generate_loop,
    loop_name,
    loop_seed,
    parse_loop_name,
    sharpest_turn_deg,
    turn_bin,
    width_bin,
)
from lfd_track.world.track import load_track, loop_track, vertex_turns_rad
from lfd_track.world.track_file import parse_track

LOOPS_CHECKED = 200  # per split

# Printed once from generate_loop and pasted: a change of the generator or of its draws shows here.
PINNED = {
    ("train", 0): (
        0.304,
        [
            [0.0, 0.0],
            [1.846785, 0.0],
            [3.203657, 1.573199],
            [3.485248, 2.400465],
            [1.942726, 4.919977],
            [0.009121, 5.233214],
            [-1.447432, 4.02317],
            [-1.828642, 2.094922],
            [-1.60035, 1.542359],
        ],
    ),
    ("validation", 5): (
        0.332,
        [
            [0.0, 0.0],
            [1.93475, 0.0],
            [1.328682, 2.373623],
            [-0.37159, 2.674757],
            [-0.134168, 0.408405],
            [-2.370758, 0.047246],
            [-0.759192, -2.324549],
            [0.24831, -1.404032],
        ],
    ),
    ("test", 17): (
        0.377,
        [
            [0.0, 0.0],
            [1.952219, 0.0],
            [2.990537, -0.693643],
            [4.494703, 0.709322],
            [4.473311, 1.692048],
            [2.833125, 1.302005],
            [1.752587, 2.438587],
            [-0.643466, 2.815955],
        ],
    ),
}


@pytest.fixture(scope="module")
def drawn() -> dict[str, list[tuple[np.ndarray, float, dict[str, int]]]]:
    return {
        split: [generate_loop(loop_seed(split, i)) for i in range(LOOPS_CHECKED)]
        for split in SPLITS
    }


def test_every_loop_is_a_valid_track_file_of_the_distribution(drawn) -> None:
    d = DEFAULT_LOOPS
    for split, found in drawn.items():
        for i, (vertices, width, corners) in enumerate(found):
            table = {"closed": True, "width_m": width, "vertices": vertices.tolist()}
            parse_track({**table, "corners": corners}, f"{split} {i}")  # raises if refused
            n = len(vertices)
            assert d.min_corners <= n <= d.max_corners
            assert corners == {str(k + 1): k for k in range(n)}
            assert d.min_width_m <= width <= d.max_width_m
            turns = np.degrees(vertex_turns_rad(vertices, True))
            assert turns.sum() == pytest.approx(360.0, abs=1e-6)  # counter-clockwise
            magnitudes = np.abs(turns)
            assert magnitudes.min() >= d.min_turn_deg - 1e-3
            assert magnitudes.max() <= d.max_turn_deg + 1e-3
            lengths = np.linalg.norm(np.roll(vertices, -1, axis=0) - vertices, axis=1)
            assert lengths.min() >= d.min_straight_widths * width - 1e-5
            assert lengths.max() <= d.max_straight_m + 1e-5
            span = vertices.max(axis=0) - vertices.min(axis=0) + 2 * width
            assert span.max() <= d.floor_m
            assert tuple(vertices[0]) == (0.0, 0.0)


def test_the_distribution_covers_its_range(drawn) -> None:
    every = [loop for found in drawn.values() for loop in found]
    turns = np.concatenate([np.degrees(vertex_turns_rad(v, True)) for v, _, _ in every])
    assert (turns < 0).mean() > 0.05  # right turns on counter-clockwise loops
    assert turns.min() < -90 and turns.max() > 150
    assert {len(v) for v, _, _ in every} == set(range(3, 11))
    sharpest = [float(np.abs(np.degrees(vertex_turns_rad(v, True))).max()) for v, _, _ in every]
    assert {turn_bin(s) for s in sharpest} == set(TURN_BIN_LABELS)
    assert {width_bin(w) for _, w, _ in every} == set(WIDTH_BIN_LABELS)
    straights = np.concatenate(
        [np.linalg.norm(np.roll(v, -1, axis=0) - v, axis=1) for v, _, _ in every]
    )
    assert straights.min() < 0.5 and straights.max() > 2.7


@pytest.mark.parametrize(("split", "index"), list(PINNED))
def test_pinned_loops(split: str, index: int) -> None:
    width, vertices = PINNED[(split, index)]
    got, got_width, _ = generate_loop(loop_seed(split, index))
    assert got_width == pytest.approx(width, abs=1e-12)
    np.testing.assert_allclose(got, np.array(vertices), rtol=0, atol=1e-9)


def test_same_seed_same_loop_and_splits_disjoint() -> None:
    first, _, _ = generate_loop(12345)
    again, _, _ = generate_loop(12345)
    assert first.tobytes() == again.tobytes()
    seeds = {split: {loop_seed(split, i) for i in (0, 1, LOOPS_PER_SPLIT - 1)} for split in SPLITS}
    assert not seeds["train"] & seeds["validation"]
    assert not seeds["validation"] & seeds["test"]
    assert not seeds["train"] & seeds["test"]
    assert loop_seed("train", LOOPS_PER_SPLIT - 1) < loop_seed("validation", 0)
    assert loop_seed("validation", LOOPS_PER_SPLIT - 1) < loop_seed("test", 0)
    a, _, _ = generate_loop(loop_seed("train", 3))
    b, _, _ = generate_loop(loop_seed("test", 3))
    assert a.shape != b.shape or not np.array_equal(a, b)


def test_loop_track_and_load_track_by_name() -> None:
    track = loop_track("test", 17)
    assert track.name == track.source == "random:test:17"
    assert track.closed and [c.label for c in track.corners][-1] == "1"
    loaded = load_track("random:test:17", reverse=True, start_corner="3")
    assert loaded.reversed and loaded.name == "random:test:17"
    forward = load_track("random:test:17")
    np.testing.assert_array_equal(forward.vertices, track.vertices)
    assert sharpest_turn_deg(track) == pytest.approx(
        max(abs(c.turn_deg) for c in track.corners), abs=1e-9
    )


def test_names() -> None:
    assert loop_name("test", 17) == "random:test:17"
    assert parse_loop_name("random:validation:0") == ("validation", 0)
    assert parse_loop_name(loop_name("train", LOOPS_PER_SPLIT - 1)) == (
        "train",
        LOOPS_PER_SPLIT - 1,
    )
    assert loops.drawn_split("random") == "train"
    assert loops.drawn_split("random:test") == "test"
    assert loops.drawn_split("random:test:1") is None
    assert loops.drawn_split("testing") is None


@pytest.mark.parametrize(
    "name",
    [
        "random",
        "random:test",
        "random:exam:3",
        "random:test:x",
        "random:test:-1",
        "random:test:017",
        "random:test:1000000",
        "random:test:1:2",
        "random::1",
    ],
)
def test_bad_loop_names_are_refused_in_one_line(name: str) -> None:
    with pytest.raises(LfdTrackError) as caught:
        load_track(name)
    message = str(caught.value)
    assert "\n" not in message and name in message


@pytest.mark.parametrize(("split", "index"), [("exam", 0), ("test", -1), ("test", 10**6)])
def test_bad_split_or_index_refused(split: str, index: int) -> None:
    with pytest.raises(LfdTrackError, match="split|index"):
        loop_name(split, index)


def test_bins() -> None:
    assert [turn_bin(d) for d in (0, 60, 60.1, 100, 135, 135.1, 165)] == [
        "<=60",
        "<=60",
        "60-100",
        "60-100",
        "100-135",
        ">135",
        ">135",
    ]
    assert turn_bin(-150) == ">135"
    assert [width_bin(w) for w in (0.25, 0.30, 0.31, 0.311, 0.38, 0.45)] == [
        "0.25-0.31",
        "0.25-0.31",
        "0.25-0.31",
        "0.31-0.38",
        "0.31-0.38",
        "0.38-0.45",
    ]
    with pytest.raises(ValueError, match="strip width"):
        width_bin(0.5)
    assert math.isclose(sharpest_turn_deg(load_track("testing")), 135.0, abs_tol=1e-9)


def test_a_bad_distribution_is_refused() -> None:
    with pytest.raises(ValueError, match="LoopDistribution"):
        LoopDistribution(min_corners=2)
    with pytest.raises(ValueError, match="LoopDistribution"):
        LoopDistribution(max_turn_deg=175.0)
    with pytest.raises(ValueError, match="LoopDistribution"):
        LoopDistribution(min_width_m=0.2)
