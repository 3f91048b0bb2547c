"""The ``fresh_felt`` memory: a dead-reckoned map of felt not yet driven along, and the rule on it."""

import dataclasses
import math

import numpy as np
import pytest
from lfd_test_support import library_with_road

from lfd_track.core.commands import Command
from lfd_track.core.frame import GRID_COLUMNS, GRID_ROWS, N_REGIONS
from lfd_track.envs.track_env import LfDTrackEnv
from lfd_track.learning.mirror import mirror_cases
from lfd_track.policy.controller import Controller
from lfd_track.policy.memory import (
    MAP_FRAMES,
    PIVOT_DEG,
    FreshFeltConfig,
    FreshFeltMemory,
    LastBendConfig,
    MemoryConfig,
    fresh_bearing_rad,
    memory_config,
    memory_for,
    policy_inputs,
    region_floor_points,
)
from lfd_track.teaching import Arbiter, Perception, TeachingLoop
from lfd_track.teaching.handwritten import FreshFeltRule, FreshFeltRuleConfig

F, L, R = Command.FORWARD, Command.LEFT, Command.RIGHT
FRESH = FreshFeltConfig.plain()


def _values(columns: set[int], rows: set[int] | None = None) -> np.ndarray:
    """Road values (40,): felt (1.0) in the given grid columns (and rows), carpet (0) elsewhere."""
    grid = np.zeros((GRID_ROWS, GRID_COLUMNS))
    for r in rows if rows is not None else range(GRID_ROWS):
        for c in columns:
            grid[r, c] = 1.0
    return grid.reshape(N_REGIONS)


def _bearing_deg(inputs: np.ndarray) -> float:
    return math.degrees(fresh_bearing_rad(inputs))


def test_region_points_lie_ahead_and_mirror_about_the_axis():
    points = region_floor_points()
    assert points.shape == (N_REGIONS, 2)
    assert np.all(points[:, 0] > 0.25) and np.all(points[:, 0] < 1.85)  # the camera's stated view
    grid = points.reshape(GRID_ROWS, GRID_COLUMNS, 2)
    np.testing.assert_allclose(grid[:, ::-1, 1], -grid[:, :, 1], atol=1e-9)
    assert np.all(np.diff(grid[:, :, 0], axis=0) < 0)  # the top row looks furthest


def test_no_felt_gives_the_neutral_inputs_and_felt_ahead_a_bearing_of_zero():
    memory = FreshFeltMemory(FRESH)
    np.testing.assert_array_equal(memory.inputs(), [0.5, 0.0, 0.0])
    memory.see(_values(set()))
    np.testing.assert_array_equal(memory.inputs(), [0.5, 0.0, 0.0])
    memory.see(_values({3, 4}))
    bearing, amount, distance = memory.inputs()
    assert bearing == pytest.approx(0.5, abs=1e-12)
    assert 0.0 < amount <= 1.0 and 0.0 < distance < 1.0


def test_felt_on_the_left_gives_a_bearing_above_a_half_and_right_below():
    left, right = FreshFeltMemory(FRESH), FreshFeltMemory(FRESH)
    left.see(_values({0, 1, 2}))
    right.see(_values({5, 6, 7}))
    assert left.inputs()[0] > 0.5 > right.inputs()[0]
    assert left.inputs()[0] - 0.5 == pytest.approx(0.5 - right.inputs()[0], abs=1e-12)


def test_a_pivot_moves_the_remembered_felt_the_other_way_by_the_pivot_angle():
    memory = FreshFeltMemory(FRESH)
    memory.see(_values({3, 4}))
    memory.note(L)
    memory.see(_values(set()))  # the felt left the picture: the map still has it
    assert _bearing_deg(memory.inputs()) == pytest.approx(-PIVOT_DEG, abs=1e-9)
    memory.note(R)
    memory.note(R)
    memory.see(_values(set()))
    assert _bearing_deg(memory.inputs()) == pytest.approx(PIVOT_DEG, abs=1e-9)


def test_felt_where_the_rover_has_been_is_not_fresh():
    memory = FreshFeltMemory(FRESH)
    memory.see(_values({3, 4}, rows={4}))  # a patch of felt just ahead (0.29 m)
    assert memory.inputs()[1] > 0
    for _ in range(3):  # drive over it: 0.3 m
        memory.note(F)
    memory.see(_values(set()))
    np.testing.assert_array_equal(memory.inputs(), [0.5, 0.0, 0.0])


def test_felt_behind_the_axle_and_beyond_reach_does_not_count():
    memory = FreshFeltMemory(FreshFeltConfig.plain(reach_m=0.5))
    memory.see(_values({3, 4}, rows={0, 1}))  # 0.8 m and 1.3 m ahead: beyond 0.5 m
    assert memory.inputs()[1] == 0.0
    memory = FreshFeltMemory(FRESH)
    memory.see(_values({3, 4}, rows={4}))
    for _ in range(8):  # turn round: the patch now lies behind
        memory.note(L)
    memory.see(_values(set()))
    assert memory.inputs()[1] == 0.0


def test_the_map_forgets_frames_beyond_its_length_and_reset_forgets_all():
    memory = FreshFeltMemory(FreshFeltConfig.plain(path_radius_m=0.0))
    memory.see(_values({0}))
    for _ in range(MAP_FRAMES - 1):
        memory.see(_values(set()))
    assert memory.inputs()[1] > 0
    memory.see(_values(set()))  # the frame with felt is one beyond the map's length: forgotten
    assert memory.inputs()[1] == 0.0
    memory.see(_values({0}))
    memory.reset()
    np.testing.assert_array_equal(memory.inputs(), [0.5, 0.0, 0.0])


def test_settings_are_checked_and_written_in_full_for_this_kind():
    assert isinstance(memory_for(FRESH), FreshFeltMemory)
    assert policy_inputs(FRESH) == N_REGIONS + 3
    assert MemoryConfig.from_dict(FRESH.to_dict()) == FRESH
    assert LastBendConfig().to_dict() == {"kind": "last_bend"}
    assert set(FRESH.to_dict()) == {"kind", *(f.name for f in dataclasses.fields(FreshFeltConfig))}
    for bad in (
        {"frames": 25},  # the map's length, step and pivot are constants now
        {"reach_m": 0.0},
        {"path_radius_m": -1.0},
        {"reach_m": float("nan")},
        {"carpet": 0.3},
        {"bearing_range_deg": True},
    ):
        with pytest.raises(ValueError, match="memory"):
            memory_config({"kind": "fresh_felt", **bad})


def test_mirroring_swaps_the_bearing_side_and_keeps_amount_and_distance():
    x = np.hstack([np.random.default_rng(0).random((4, N_REGIONS)), [[0.7, 0.4, 0.3]] * 4])
    a = np.array([0, 1, 2, 0])
    mx, ma = mirror_cases(x, a, memory=FRESH)
    np.testing.assert_allclose(mx[:, N_REGIONS:], [[0.3, 0.4, 0.3]] * 4, atol=1e-12)
    assert ma.tolist() == [0, 2, 1, 0]


def test_the_rule_turns_toward_fresh_felt_and_keeps_turning_when_there_is_none():
    rule = FreshFeltRule(FreshFeltRuleConfig(turn_deg=15.0))
    ahead, left, right = 0.5, 0.5 + 20 / 360, 0.5 - 20 / 360
    assert rule.act(np.array([ahead, 0.5, 0.5])) == F
    assert rule.act(np.array([left, 0.5, 0.5])) == L
    assert rule.act(np.array([0.5, 0.0, 0.0])) == L  # none: the side it last lay on
    assert rule.act(np.array([right, 0.5, 0.5])) == R
    assert rule.act(np.array([0.5, 0.0, 0.0])) == R
    assert rule.blank_frames == 2
    rule.reset()
    assert rule.act(np.array([0.5, 0.0, 0.0])) == L
    with pytest.raises(ValueError, match="fresh_felt"):
        FreshFeltRuleConfig(memory=LastBendConfig())


def test_perception_feeds_each_frame_to_the_map_and_the_loop_moves_it():
    """In the loop the map sees every frame's road values and moves with every command."""
    env = LfDTrackEnv(track="training")
    perception = Perception(library_with_road()[0], "frozen", FRESH)
    rule = FreshFeltRule()
    loop = TeachingLoop(env, perception, Arbiter("policy"), policy=rule)
    loop.reset(seed=3)
    loop.run()
    env.close()
    assert loop.info["success"]  # the rule follows the training track from end to end
    assert rule.blank_frames < loop.counts.steps


def test_a_controller_with_this_memory_saves_loads_and_drives_the_same(tmp_path):
    library, _ = library_with_road()
    weights = np.random.default_rng(1).uniform(-1, 1, 5 * (N_REGIONS + 3) + 15)
    controller = Controller(library, weights, memory=FRESH)
    path = tmp_path / "c.json"
    controller.save(path)
    loaded = Controller.load(path)
    assert loaded.memory == FRESH
    x = np.hstack([np.random.default_rng(2).random((20, N_REGIONS)), np.full((20, 3), 0.5)])
    assert [loaded.act_on_values(v) for v in x] == [controller.act_on_values(v) for v in x]


def test_blank_bearing_last_keeps_the_side_of_the_last_fresh_felt():
    last = FreshFeltMemory(FreshFeltConfig.plain(blank_bearing="last"))
    centre = FreshFeltMemory(FRESH)
    for memory in (last, centre):
        memory.see(_values({7}, rows={4}))  # felt just ahead, on the right
        for _ in range(4):  # drive past it: nothing fresh is left
            memory.note(F)
        memory.see(_values(set()))
        memory.see(_values(set()))
    assert last.inputs()[0] < 0.5 and last.inputs()[1:].tolist() == [0.0, 0.0]
    np.testing.assert_array_equal(centre.inputs(), [0.5, 0.0, 0.0])
    last.reset()
    last.see(_values(set()))
    np.testing.assert_array_equal(last.inputs(), [0.5, 0.0, 0.0])  # nothing seen yet: centre


def test_blank_bearing_is_checked_and_written_only_when_last():
    with pytest.raises(ValueError, match="memory blank_bearing must be one of centre, last"):
        FreshFeltConfig.plain(blank_bearing="left")
    assert FRESH.to_dict()["blank_bearing"] == "centre"  # every setting is written
    last = FreshFeltConfig.plain(blank_bearing="last")
    assert last.to_dict()["blank_bearing"] == "last"
    assert MemoryConfig.from_dict(last.to_dict()) == last


def test_a_narrower_bearing_range_spreads_and_clips_the_bearing_input():
    narrow = FreshFeltConfig.plain(bearing_range_deg=30.0)
    wide_memory, narrow_memory = FreshFeltMemory(FRESH), FreshFeltMemory(narrow)
    for memory in (wide_memory, narrow_memory):
        memory.see(_values({2}, rows={3, 4}))  # felt a little left of ahead
    wide, spread = wide_memory.inputs(), narrow_memory.inputs()
    bearing = fresh_bearing_rad(wide)
    assert 0.0 < math.degrees(bearing) < 30.0
    assert spread[0] - 0.5 == pytest.approx((wide[0] - 0.5) * 6.0, abs=1e-12)  # 180 / 30
    assert fresh_bearing_rad(spread, 30.0) == pytest.approx(bearing, abs=1e-12)
    np.testing.assert_array_equal(spread[1:], wide[1:])  # amount and distance unchanged
    far = FreshFeltMemory(narrow)
    far.see(_values({0}, rows={4}))  # felt far to the left of the nearest row: beyond 30 deg
    assert far.inputs()[0] == 1.0
    assert math.degrees(fresh_bearing_rad(far.inputs(), 30.0)) == pytest.approx(30.0, abs=1e-9)


def test_the_rule_reads_the_bearing_with_its_maps_range():
    narrow = FreshFeltConfig.plain(bearing_range_deg=30.0)
    rule = FreshFeltRule(FreshFeltRuleConfig(turn_deg=20.0, memory=narrow))
    # 15 deg left: 0.75 in a +-30 deg range (0.54 in the full circle's); 25 deg right: 0.083.
    assert rule.act(np.array([0.5 + 15 / 60, 0.5, 0.5])) == F
    assert rule.act(np.array([0.5 - 25 / 60, 0.5, 0.5])) == R
    assert rule.act(np.array([1.0, 0.5, 0.5])) == L
    with pytest.raises(ValueError, match="bearing_range_deg"):
        FreshFeltRuleConfig(turn_deg=30.0, memory=narrow)


def test_bearing_range_is_checked_and_written_only_when_narrower():
    for bad in (0.0, -10.0, 190.0, True, "30"):
        with pytest.raises(ValueError, match="memory bearing_range_deg"):
            FreshFeltConfig.plain(bearing_range_deg=bad)
    assert FRESH.to_dict()["bearing_range_deg"] == 180.0  # every setting is written
    narrow = FreshFeltConfig.plain(bearing_range_deg=30.0)
    assert narrow.to_dict()["bearing_range_deg"] == 30.0
    assert MemoryConfig.from_dict(narrow.to_dict()) == narrow


def test_strip_link_keeps_only_the_felt_connected_to_the_rovers_own_strip():
    """Felt ahead of the rover (columns 3-4 of the two nearest rows) and a patch across carpet on
    the left (column 0): without the option the patch pulls the bearing left; with links of
    0.15 m it is not on the rover's strip and the bearing is straight ahead."""
    values = _values({3, 4}, rows={3, 4}) + _values({0}, rows={3})
    plain = FreshFeltMemory(FreshFeltConfig.plain())
    strip = FreshFeltMemory(FreshFeltConfig.plain(strip_link_m=0.15))
    plain.see(values)
    strip.see(values)
    assert _bearing_deg(plain.inputs()) > 5.0
    assert abs(_bearing_deg(strip.inputs())) < 1e-6
    assert strip.inputs()[1] < plain.inputs()[1]
    lonely = FreshFeltMemory(FreshFeltConfig.plain(strip_link_m=0.15))
    lonely.see(_values({0}, rows={3}))  # felt, but none under the rover: no strip, nothing fresh
    np.testing.assert_array_equal(lonely.inputs(), [0.5, 0.0, 0.0])


def test_fresh_sight_leaves_out_felt_seen_only_across_carpet():
    """Felt ahead of the rover (columns 3-4 of the two nearest rows) and a patch on the left of
    the second nearest row (column 0) with carpet between: without the option the patch pulls
    the bearing left; with fresh_sight_m the line from the axle to it crosses the carpet of the
    nearest row, so only the felt straight ahead is fresh. Felt reached along felt is left as it
    was."""
    values = _values({3, 4}, rows={3, 4}) + _values({0}, rows={3})
    plain = FreshFeltMemory(FRESH)
    sight = FreshFeltMemory(FreshFeltConfig.plain(fresh_sight_m=0.05))
    plain.see(values)
    sight.see(values)
    assert _bearing_deg(plain.inputs()) > 5.0
    assert abs(_bearing_deg(sight.inputs())) < 1e-6
    assert sight.inputs()[1] < plain.inputs()[1]
    ahead = _values({3, 4})  # a strip straight ahead in every row: all of it in sight
    plain.reset(), sight.reset()
    plain.see(ahead)
    sight.see(ahead)
    np.testing.assert_array_equal(sight.inputs(), plain.inputs())
    assert sight.config.to_dict()["fresh_sight_m"] == 0.05
    assert FRESH.to_dict()["fresh_sight_m"] == 0.0
    assert MemoryConfig.from_dict(sight.config.to_dict()) == sight.config
    with pytest.raises(ValueError, match="memory fresh_sight_m"):
        FreshFeltConfig.plain(fresh_sight_m=0.5)


def test_blank_reach_looks_further_only_while_nothing_is_fresh_near():
    far_only = _values({3, 4}, rows={1})  # felt 0.79 m ahead: beyond reach_m (0.6)
    plain = FreshFeltMemory(FRESH)
    wide = FreshFeltMemory(FreshFeltConfig.plain(blank_reach_m=1.0))
    plain.see(far_only)
    wide.see(far_only)
    np.testing.assert_array_equal(plain.inputs(), [0.5, 0.0, 0.0])
    bearing, amount, distance = wide.inputs()
    assert bearing == pytest.approx(0.5, abs=1e-12) and amount > 0
    centre = region_floor_points()[[8 + 3, 8 + 4]].mean(axis=0)  # row 1, columns 3 and 4
    assert distance == pytest.approx(np.hypot(*centre) / 1.0, abs=1e-9)  # over the wider reach
    near = _values({3, 4}, rows={1, 4})  # felt near too: the usual reach decides
    plain.reset(), wide.reset()
    plain.see(near)
    wide.see(near)
    np.testing.assert_array_equal(wide.inputs(), plain.inputs())


def test_strip_and_blank_reach_are_checked_and_written_only_when_set():
    assert FRESH.to_dict()["strip_link_m"] == 0.0 and FRESH.to_dict()["blank_reach_m"] == 0.0
    both = FreshFeltConfig.plain(strip_link_m=0.15, blank_reach_m=1.0)
    assert both.to_dict()["strip_link_m"] == 0.15 and both.to_dict()["blank_reach_m"] == 1.0
    assert MemoryConfig.from_dict(both.to_dict()) == both
    with pytest.raises(ValueError, match="unknown memory setting 'strip_link_m' for kind 'last_"):
        memory_config({"kind": "last_bend", "strip_link_m": 0.15})
    with pytest.raises(ValueError, match="memory blank_reach_m must be 0"):
        FreshFeltConfig.plain(blank_reach_m=0.5)
    with pytest.raises(ValueError, match="memory strip_link_m"):
        FreshFeltConfig.plain(strip_link_m=-0.1)


def test_a_strip_from_the_nearest_felt_keeps_a_rover_that_drifted_off_it_going():
    """Felt only 0.54 m ahead (row 2) and none under the rover: a strip that starts at the axle
    finds nothing fresh; one that starts from the nearest felt finds that felt, straight ahead."""
    ahead = _values({2, 3, 4, 5}, rows={2})
    axle = FreshFeltMemory(FreshFeltConfig.plain(strip_link_m=0.15))
    nearest = FreshFeltMemory(FreshFeltConfig.plain(strip_link_m=0.15, strip_from="nearest"))
    axle.see(ahead)
    nearest.see(ahead)
    np.testing.assert_array_equal(axle.inputs(), [0.5, 0.0, 0.0])
    assert nearest.inputs()[1] > 0 and abs(_bearing_deg(nearest.inputs())) < 1e-6
    assert nearest.config.to_dict()["strip_from"] == "nearest"
    assert axle.config.to_dict()["strip_from"] == "axle"
    with pytest.raises(ValueError, match="memory strip_from must be one of axle, nearest"):
        FreshFeltConfig.plain(strip_from="middle")


def test_every_command_leaves_a_place_on_the_path():
    """After 3 m forward, 40 pivots on the spot: every command leaves a place, so the path is
    only the spot (the strip behind is fresh again)."""
    plain = FreshFeltMemory(FRESH)
    for _ in range(30):
        plain.note(F)
    for _ in range(40):
        plain.note(L)
    assert len(plain._path) == 40 and np.allclose(plain._path, 0.0)


def test_blank_distance_reach_reads_felt_found_further_as_at_the_edge_of_reach():
    far_only = _values({3, 4}, rows={1})  # felt 0.79 m ahead: beyond reach_m (0.6)
    wide = FreshFeltMemory(FreshFeltConfig.plain(blank_reach_m=1.0))
    edge = FreshFeltMemory(FreshFeltConfig.plain(blank_reach_m=1.0, blank_distance="reach"))
    wide.see(far_only)
    edge.see(far_only)
    assert wide.inputs()[2] < 1.0 and edge.inputs()[2] == 1.0  # 0.79 / 0.6, clipped
    np.testing.assert_array_equal(wide.inputs()[:2], edge.inputs()[:2])
    near = _values({3, 4}, rows={4})  # felt within reach: the option changes nothing
    wide.reset(), edge.reset()
    wide.see(near)
    edge.see(near)
    np.testing.assert_array_equal(wide.inputs(), edge.inputs())
    assert edge.config.to_dict()["blank_distance"] == "reach"
    assert wide.config.to_dict()["blank_distance"] == "blank_reach"
    with pytest.raises(ValueError, match="memory blank_distance must be one of blank_reach, r"):
        FreshFeltConfig.plain(blank_distance="far")


def test_visited_fade_weighs_felt_by_how_far_it_lies_beyond_the_path_radius():
    """Felt 0.35-0.6 m ahead after one step forward: with a fade of 0.3 m the felt just beyond
    the path radius weighs less, so less fresh felt is left and its centre lies further."""
    values = _values({2, 3, 4, 5})
    hard = FreshFeltMemory(FRESH)
    soft = FreshFeltMemory(FreshFeltConfig.plain(visited_fade_m=0.3))
    for memory in (hard, soft):
        memory.note(F)
        memory.see(values)
    assert 0 < soft.inputs()[1] < hard.inputs()[1]
    assert soft.inputs()[2] > hard.inputs()[2]
    assert soft.config.to_dict()["visited_fade_m"] == 0.3
    assert FRESH.to_dict()["visited_fade_m"] == 0.0
    with pytest.raises(ValueError, match="memory visited_fade_m must be a finite number >= 0"):
        FreshFeltConfig.plain(visited_fade_m=-0.1)


def test_picture_links_join_the_far_rows_a_strip_link_cannot_reach():
    """A strip straight ahead in every row of one frame: the floor points of the second row
    (0.79 m) lie 0.25 m beyond the next row's, so links of 0.15 m leave them off the rover's
    strip; regions that touch in the picture join them. The far row (1.31 m) lies beyond the
    1.2 m within which felt is linked at all, and felt that touches nothing (a patch in the
    far left corner, across carpet) stays off."""
    values = _values({3, 4}) + _values({0}, rows={1})
    plain = FreshFeltMemory(FreshFeltConfig.plain(strip_link_m=0.15))
    linked = FreshFeltMemory(FreshFeltConfig.plain(strip_link_m=0.15, strip_picture_links=True))
    on = {}
    for name, memory in (("plain", plain), ("linked", linked)):
        memory.see(values)
        dist = np.hypot(*memory._points.T)
        on[name] = set(np.flatnonzero(memory._own_strip(dist)))
    strip = {r * GRID_COLUMNS + c for r in range(1, GRID_ROWS) for c in (3, 4)}
    assert on["plain"] == strip - {GRID_COLUMNS + 3, GRID_COLUMNS + 4}
    assert on["linked"] == strip
    assert linked.config.to_dict()["strip_picture_links"] is True
    assert plain.config.to_dict()["strip_picture_links"] is False
    with pytest.raises(ValueError, match="memory strip_picture_links must be true or false"):
        FreshFeltConfig.plain(strip_picture_links=1)


def _strip_values(x: float, y: float, heading: float) -> np.ndarray:
    """Road values of the paper camera at pose (x, y, heading) over a 0.30 m strip from x = 0 to
    1.6 m whose centre runs 0.35 m left of the line y = 0 (felt 1, carpet 0)."""
    points = region_floor_points()
    cos, sin = math.cos(heading), math.sin(heading)
    wx = x + cos * points[:, 0] - sin * points[:, 1]
    wy = y + sin * points[:, 0] + cos * points[:, 1]
    return ((np.abs(wy - 0.35) <= 0.15) & (wx >= 0.0) & (wx <= 1.6)).astype(np.float64)


@pytest.mark.parametrize("visited_from", ["path", "strip", "path_and_centreline"])
def test_a_strip_ridden_along_its_edge_is_visited_across_its_width_only_from_the_strip(
    visited_from,
):
    # The rover drives along y = 0, the strip's right edge lying 0.2 m to its left, then turns
    # round on the spot. Measured from its path alone the strip's far half (0.35-0.5 m off) is
    # fresh, and the map points the turned rover back along it; with visited_from = "strip" or
    # "path_and_centreline" the centres of the felt abeam make the whole strip visited, and the
    # map is blank at the end.
    memory = FreshFeltMemory(FreshFeltConfig(visited_from=visited_from, geometry="paper"))
    x, heading = 0.0, 0.0
    memory.see(_strip_values(x, 0.0, heading))
    for _ in range(12):
        memory.note(F)
        x += 0.1
        memory.see(_strip_values(x, 0.0, heading))
    amounts = []
    for _ in range(8):  # 183 degrees
        memory.note(L)
        heading += math.radians(PIVOT_DEG)
        memory.see(_strip_values(x, 0.0, heading))
        amounts.append(memory.inputs()[1])
    if visited_from == "path":
        assert min(amounts[-3:]) > 0.1 and memory.bearing_deg < -30.0  # back along, to the right
    else:
        assert amounts[-1] == 0.0 and memory.bearing_deg is None


_HAIRPIN_VERTEX = np.array([1.6, 0.0])
_HAIRPIN_OUT = np.array([math.cos(math.radians(160.0)), math.sin(math.radians(160.0))])


def _on_strip(wx, wy, start, direction, length, half=0.15):
    rx, ry = wx - start[0], wy - start[1]
    along = rx * direction[0] + ry * direction[1]
    across = -rx * direction[1] + ry * direction[0]
    return (along >= -half) & (along <= length + half) & (np.abs(across) <= half)


def _hairpin_values(x: float, y: float, heading: float) -> np.ndarray:
    """Road values of the paper camera at a 160-degree hairpin: a 0.30 m strip along y = 0 up to
    x = 1.6 m, and the outgoing one leaving that vertex back to the left."""
    points = region_floor_points()
    cos, sin = math.cos(heading), math.sin(heading)
    wx = x + cos * points[:, 0] - sin * points[:, 1]
    wy = y + sin * points[:, 0] + cos * points[:, 1]
    incoming = _on_strip(wx, wy, np.array([-1.0, 0.0]), np.array([1.0, 0.0]), 2.6)
    return (incoming | _on_strip(wx, wy, _HAIRPIN_VERTEX, _HAIRPIN_OUT, 2.0)).astype(np.float64)


def test_a_hairpins_outgoing_strip_comes_back_fresh_sooner_measured_from_the_centreline():
    # The rover drives the incoming strip's centre to 0.2 m before the vertex, turns 160 degrees
    # left and drives on along the outgoing strip, which runs within 0.35 m of the incoming one
    # for its first metre. Measured from the path (or the path and the strip's centres), that
    # metre is visited; measured from the centreline (felt within 0.25 m of the strip's centres),
    # only its part nearer the incoming strip's line is.
    amounts = {}
    for visited_from in ("path", "strip", "centreline", "path_and_centreline"):
        memory = FreshFeltMemory(FreshFeltConfig(visited_from=visited_from, geometry="paper"))
        x, y, heading = -0.5, 0.0, 0.0
        memory.see(_hairpin_values(x, y, heading))
        for _ in range(19):
            memory.note(F)
            x += 0.1
            memory.see(_hairpin_values(x, y, heading))
        for _ in range(7):
            memory.note(L)
            heading += math.radians(PIVOT_DEG)
            memory.see(_hairpin_values(x, y, heading))
        for _ in range(4):
            memory.note(F)
            x, y = x + 0.1 * math.cos(heading), y + 0.1 * math.sin(heading)
            memory.see(_hairpin_values(x, y, heading))
        amounts[visited_from] = memory.inputs()[1]
    assert amounts["centreline"] > 0.4 > 0.25 > max(amounts["path"], amounts["strip"])
    # the path with the band around the centres hides no more of it than the path alone
    assert amounts["path_and_centreline"] == pytest.approx(amounts["path"], abs=1e-9)
