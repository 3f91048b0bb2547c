"""The ``fresh_felt`` map's ``branch_side`` input: which side felt branched off the rover's strip,
its mirror image, the rule on it, and a controller that reads it."""

import numpy as np
import pytest

from lfd_track.core.commands import Command
from lfd_track.core.frame import GRID_COLUMNS, GRID_ROWS, N_REGIONS
from lfd_track.learning.mirror import mirror_cases
from lfd_track.policy.branch_side import (
    UNKNOWN,
    WINDOW_FORWARD,
    BranchSide,
    frame_value,
    side_command,
)
from lfd_track.policy.controller import Controller
from lfd_track.policy.memory import FreshFeltConfig, FreshFeltMemory, memory_config, policy_inputs
from lfd_track.teaching.handwritten import FreshFeltRule, FreshFeltRuleConfig
from lfd_track.vision.synthetic import patch_library, synthetic_frames

F, L, R = Command.FORWARD, Command.LEFT, Command.RIGHT
BRANCH = FreshFeltConfig(branch_side=True)


def _values(cells: set[tuple[int, int]]) -> np.ndarray:
    """Road values (40,): felt (1.0) at the (row, column) cells, carpet elsewhere."""
    grid = np.zeros((GRID_ROWS, GRID_COLUMNS))
    for row, column in cells:
        grid[row, column] = 1.0
    return grid.reshape(N_REGIONS)


STRIP = {(r, c) for r in range(GRID_ROWS) for c in (3, 4)}
LEFT_BRANCH = STRIP | {(0, 0), (0, 1)}  # felt 0.4-0.56 m left of the strip, 1.3 m ahead
RIGHT_BRANCH = STRIP | {(0, 6), (0, 7)}


#: A map's arrays (rover frame) for the windows' own tests: the path behind the axle, the strip
#: ahead along x, and felt 0.5 m to the left of it 0.6-0.8 m ahead.
MAP_PATH = np.array([[-0.6, 0.0], [-0.4, 0.0], [-0.2, 0.0]])
MAP_POINTS = np.array(
    [[x, 0.0] for x in (-0.3, -0.1, 0.2, 0.5)] + [[0.6, 0.5], [0.7, 0.5], [0.8, 0.5]]
)


def _see(side: BranchSide) -> float:
    """``side``'s input after a frame that placed all of :data:`MAP_POINTS`, all felt."""
    return side.see(MAP_POINTS, np.ones(len(MAP_POINTS)), MAP_PATH, len(MAP_POINTS))


def _seen_left(window: str) -> tuple[BranchSide, float]:
    """A branch side with ``window`` after a forward step and that frame, and its input."""
    side = BranchSide(window)
    side.moved(F)
    return side, _see(side)


def _drive(memory: FreshFeltMemory, frames: list[set[tuple[int, int]]]) -> list[np.ndarray]:
    """See each frame, then drive a step forward; the inputs after each frame."""
    seen = []
    for cells in frames:
        memory.see(_values(cells))
        seen.append(memory.inputs())
        memory.note(F)
    return seen


def test_the_setting_adds_a_fourth_input_and_leaves_the_other_three_as_they_were():
    assert (
        FreshFeltConfig().n_inputs == FreshFeltConfig.n_inputs == 3
        and not FreshFeltConfig().branch_side
    )
    assert BRANCH.n_inputs == 4 and policy_inputs(BRANCH, "none") == 4
    assert memory_config({"kind": "fresh_felt", "branch_side": True}) == BRANCH
    frames = [STRIP] * 5 + [LEFT_BRANCH] * 6 + [STRIP] * 4
    plain = _drive(FreshFeltMemory(FreshFeltConfig()), frames)
    with_side = _drive(FreshFeltMemory(BRANCH), frames)
    for without, with_ in zip(plain, with_side, strict=True):
        assert without.shape == (3,) and with_.shape == (4,)
        np.testing.assert_array_equal(with_[:3], without)  # the same arithmetic, the same bits


def test_felt_branching_off_to_the_left_reads_1_to_the_right_0_and_none_at_first():
    left = _drive(FreshFeltMemory(BRANCH), [STRIP] * 5 + [LEFT_BRANCH] * 4)
    right = _drive(FreshFeltMemory(BRANCH), [STRIP] * 5 + [RIGHT_BRANCH] * 4)
    assert [x[3] for x in left[:5]] == [UNKNOWN] * 5  # a straight strip has no side
    assert left[-1][3] == 1.0 and right[-1][3] == 0.0


def test_the_side_is_forgotten_a_metre_of_driving_after_the_branch_has_passed():
    memory = FreshFeltMemory(BRANCH)
    seen = _drive(memory, [STRIP] * 5 + [LEFT_BRANCH] * 3 + [STRIP] * (WINDOW_FORWARD + 15))
    assert seen[8][3] == 1.0 and seen[-1][3] == UNKNOWN  # seen 1.3 m ahead, counted from 1.2 m
    memory.reset()  # a new episode starts with no side
    memory.see(_values(STRIP))
    assert memory.inputs()[3] == UNKNOWN


def test_pivots_alone_give_no_side():
    memory = FreshFeltMemory(BRANCH)
    for command in (L, L, R, R, L):
        memory.see(_values(LEFT_BRANCH))
        memory.note(command)
    memory.see(_values(LEFT_BRANCH))
    assert memory.inputs()[3] == UNKNOWN  # no path behind the axle: no strip to branch off


def test_frame_value_counts_felt_off_the_strip_ahead_by_side():
    path = np.column_stack([-np.arange(1, 6) * 0.1, np.zeros(5)])[::-1]  # came along +x
    strip = np.column_stack([np.linspace(-0.4, 1.0, 15), np.zeros(15)])
    branch = np.array([[0.7, 0.5], [0.8, 0.6], [0.9, -0.5]])  # two left, one right
    points = np.vstack([strip, branch])
    felt = np.ones(len(points))
    assert frame_value(points, felt, path) == pytest.approx(1.0)
    felt[-3:] = 0.4  # below the felt level: not felt
    assert frame_value(points, felt, path) == 0.0
    assert frame_value(points, np.ones(len(points)), path[-1:]) == 0.0  # too little path


def test_the_mirror_image_swaps_the_side_and_keeps_none():
    inputs = np.array([[0.7, 0.3, 0.2, 1.0], [0.4, 0.1, 0.5, UNKNOWN], [0.5, 0.0, 0.0, 0.0]])
    mirrored = BRANCH.mirror(inputs)
    np.testing.assert_allclose(mirrored[:, 3], [0.0, UNKNOWN, 1.0])
    np.testing.assert_allclose(mirrored[:, 0], 1.0 - inputs[:, 0])
    x, y = mirror_cases(inputs, np.array([L, F, R]), memory=BRANCH, features="none")
    np.testing.assert_allclose(x[:, 3], [0.0, UNKNOWN, 1.0])
    assert list(y) == [R, F, L]


def test_the_rule_pivots_toward_the_branch_side_only_while_the_map_is_blank():
    rule = FreshFeltRule(FreshFeltRuleConfig(memory=FreshFeltConfig.plain(branch_side=True)))
    left_felt = np.array([0.6, 0.5, 0.4])  # fresh felt 36 deg to the left
    assert rule.act(np.append(left_felt, 0.0)) == L  # the bearing decides while felt is fresh
    assert rule.side == L
    blank = np.array([0.6, 0.0, 0.0])
    assert rule.act(np.append(blank, 0.0)) == R  # blank: toward the branch side
    assert rule.act(np.append(blank, UNKNOWN)) == L  # no side: the last side, as without it
    assert rule.act(blank) == L  # three inputs: the rule as it was
    assert side_command(1.0) == L and side_command(0.0) == R and side_command(UNKNOWN) is None


def _saved_and_loaded(tmp_path, memory: FreshFeltConfig, n_inputs: int) -> Controller:
    """A controller on ``memory``'s ``n_inputs`` map inputs (random weights, biases) saved and
    loaded again: the loaded one has the same settings and gives the same commands on the same
    frames. The controller."""
    frames = synthetic_frames(np.random.default_rng(0), 6)
    library = patch_library(frames, 32, np.random.default_rng(1))
    weights = np.random.default_rng(2).uniform(-3, 3, 5 * n_inputs + 5 + 3 * 5 + 3)
    controller = Controller(library, weights, bias=True, features="none", memory=memory)
    assert controller.n_inputs == n_inputs
    commands = [controller.act(f) for f in frames]
    path = tmp_path / "controller.json"
    controller.save(path)
    loaded = Controller.load(path)
    assert loaded.memory == memory and loaded.n_inputs == n_inputs
    assert [loaded.act(f) for f in frames] == commands
    return controller


def test_a_controller_reads_the_fourth_input_and_its_file_records_the_setting(tmp_path):
    controller = _saved_and_loaded(tmp_path, BRANCH, 4)
    weights = controller.weights
    with pytest.raises(ValueError, match="weights"):  # a 3-input network's weights do not fit
        Controller(controller.library, weights[:-5], bias=True, features="none", memory=BRANCH)


def test_with_the_commands_window_the_side_expires_while_the_rover_only_pivots():
    frames = [STRIP] * 5 + [LEFT_BRANCH] * 4
    forward = FreshFeltMemory(BRANCH)
    commands = FreshFeltMemory(FreshFeltConfig(branch_side=True, branch_window="commands"))
    for memory in (forward, commands):
        assert _drive(memory, frames)[-1][3] == 1.0
    sides = {"forward": [], "commands": []}
    for _ in range(WINDOW_FORWARD + 2):  # spin in place, seeing the branch all the while
        for name, memory in (("forward", forward), ("commands", commands)):
            memory.note(L)
            memory.see(_values(LEFT_BRANCH))
            sides[name].append(memory.inputs()[3])
    assert sides["forward"] == [1.0] * (WINDOW_FORWARD + 2)  # stale: it never expires
    assert sides["commands"][0] == 1.0 and sides["commands"][-1] == UNKNOWN
    with pytest.raises(ValueError, match="branch_window"):
        FreshFeltConfig(branch_side=True, branch_window="pivots")


def test_with_the_new_felt_window_a_frame_counts_only_the_felt_it_placed():
    old, new = MAP_POINTS, MAP_POINTS[:4]  # the branch on the map, not in the newest frame
    points, felt = np.vstack([old, new]), np.ones(len(old) + len(new))
    sides = {}
    for window in ("commands", "new_felt"):
        side = BranchSide(window)
        side.moved(F)
        sides[window] = side.see(points, felt, MAP_PATH, len(new))
    assert sides == {"commands": 1.0, "new_felt": UNKNOWN}
    side = BranchSide("new_felt")  # the frame that placed the branch counts it
    side.moved(F)
    assert side.see(old, np.ones(len(old)), MAP_PATH, len(old)) == 1.0
    with pytest.raises(ValueError, match="branch window"):
        BranchSide("pivots")


def test_with_the_heading_window_the_side_is_forgotten_after_a_quarter_turn():
    """Seen, then pivoted toward: three pivots (69 degrees) keep the side, the fourth (92) ends
    it; with "commands" it lasts until ten commands have passed. A wiggle keeps it."""
    sides = {}
    for window in ("commands", "heading"):
        memory = FreshFeltMemory(FreshFeltConfig(branch_side=True, branch_window=window))
        assert _drive(memory, [STRIP] * 5 + [LEFT_BRANCH] * 4)[-1][3] == 1.0
        sides[window] = []
        for _ in range(4):
            memory.note(L)
            memory.see(_values(LEFT_BRANCH))
            sides[window].append(memory.inputs()[3])
    assert sides["commands"] == [1.0] * 4
    assert sides["heading"] == [1.0, 1.0, 1.0, UNKNOWN]
    memory = FreshFeltMemory(FreshFeltConfig(branch_side=True, branch_window="heading"))
    _drive(memory, [STRIP] * 5 + [LEFT_BRANCH] * 4)
    for command in (L, R, L, R, L, R):  # net turn never past one pivot
        memory.note(command)
        memory.see(_values(LEFT_BRANCH))
    assert memory.inputs()[3] == 1.0


def test_with_the_behind_window_fresh_felt_behind_on_the_other_side_ends_the_side():
    sides = {}
    for window in ("commands", "behind"):
        side, left = _seen_left(window)
        assert left == 1.0
        kept = [side.contradicted(left, np.radians(b)) for b in (-60.0, 120.0, 170.0, -89.0)]
        sides[window] = kept + [side.contradicted(left, np.radians(-120.0))]
        side.moved(L)  # a pivot's frame adds nothing: the side is what is left
        sides[window].append(_see(side))
    assert sides["commands"] == [1.0] * 6  # without "behind" the bearing never ends the side
    assert sides["behind"] == [1.0, 1.0, 1.0, 1.0, UNKNOWN, UNKNOWN]  # and it stays forgotten
    right = BranchSide("behind")
    assert right.contradicted(0.0, np.radians(100.0)) == UNKNOWN
    assert right.contradicted(0.0, np.radians(-170.0)) == 0.0


def test_with_the_crossed_window_a_pivot_across_the_fresh_felt_spends_the_side():
    """A pivot toward the side that carries the felt from the side's own side to the other
    spends it; the felt on the other side from the start (a corner's tip), a forward step, or a
    blank map between do not."""

    def run(window: str, steps: list[tuple[Command, float | None]]) -> list[float]:
        side, value = _seen_left(window)
        out = [side.contradicted(value, np.radians(10.0))]  # felt 10 deg left: the side's side
        for command, bearing in steps:
            side.moved(command)
            value = _see(side)
            out.append(side.contradicted(value, None if bearing is None else np.radians(bearing)))
        return out

    crossing = [(L, -13.0), (L, -35.0)]
    assert run("commands", crossing) == [1.0, 1.0, 1.0]
    assert run("crossed", crossing) == [1.0, UNKNOWN, UNKNOWN]  # spent, and stays spent
    assert run("crossed", [(R, -13.0)]) == [1.0, 1.0]  # pivoted away: not the side's doing
    assert run("crossed", [(F, -13.0)]) == [1.0, 1.0]  # driven on: not a pivot
    assert run("crossed", [(L, None), (L, -13.0)]) == [1.0, 1.0, 1.0]  # blank between
    tip, value = _seen_left("crossed")
    assert [tip.contradicted(value, np.radians(b)) for b in (-20.0, -25.0)] == [1.0, 1.0]
    tip.moved(L)
    assert tip.contradicted(value, np.radians(-45.0)) == 1.0  # outer side from the start


def test_with_the_blank_window_the_side_is_given_only_while_the_map_is_blank():
    """``"blank"`` gives the side as ``"commands"`` does while the map has no fresh felt, and
    none while it has some, without forgetting it: the side is back at the next blank map."""
    out = {}
    for window in ("commands", "blank"):
        side, value = _seen_left(window)
        out[window] = [side.contradicted(value, b) for b in (None, 0.1, -0.3, None, 2.5, None)]
    assert out["commands"] == [1.0] * 6
    assert out["blank"] == [1.0, UNKNOWN, UNKNOWN, 1.0, UNKNOWN, 1.0]
    assert BranchSide("blank").contradicted(UNKNOWN, None) == UNKNOWN  # no side: none either


def test_the_blank_window_leaves_the_rule_on_the_map_as_it_was():
    """The rule reads the side only while the map is blank (amount 0), where ``"blank"`` gives
    what ``"commands"`` gives: over a run of inputs, the side replaced by none wherever the map
    has fresh felt, the rule's commands are the same, step for step."""
    rng = np.random.default_rng(0)
    n = 400
    inputs = np.column_stack(
        [
            rng.uniform(0, 1, n),
            np.where(rng.random(n) < 0.3, 0.0, rng.uniform(0.05, 1, n)),  # a third blank
            rng.uniform(0, 1, n),
            rng.choice([0.0, UNKNOWN, 1.0], n),
        ]
    )
    gated = inputs.copy()
    gated[gated[:, 1] > 0, 3] = UNKNOWN
    config = FreshFeltRuleConfig(memory=FreshFeltConfig.plain(branch_side=True))
    as_given, as_blank = FreshFeltRule(config), FreshFeltRule(config)
    commands = [(as_given.act(x), as_blank.act(y)) for x, y in zip(inputs, gated, strict=True)]
    assert all(a == b for a, b in commands)
    blank_turns = [
        a for (a, _), x in zip(commands, inputs, strict=True) if x[1] == 0 and x[3] != UNKNOWN
    ]
    assert {L, R} <= set(blank_turns)  # the side does turn it on blank maps


def test_a_copy_of_the_map_is_a_snapshot_of_its_branch_side_too():
    """The perception keeps a shallow copy of the map before each frame and shows views to
    copies of it: what a copy sees must not change the map it was copied from."""
    import copy

    memory = FreshFeltMemory(FreshFeltConfig(branch_side=True, branch_window="commands"))
    assert _drive(memory, [STRIP] * 5 + [LEFT_BRANCH] * 4)[-1][3] == 1.0
    snapshot = copy.copy(memory)
    before = memory.inputs()
    for _ in range(WINDOW_FORWARD + 15):  # the copy drives on past the branch
        snapshot.see(_values(STRIP))
        snapshot.note(F)
    snapshot.see(_values(STRIP))
    assert snapshot.inputs()[3] == UNKNOWN
    np.testing.assert_array_equal(memory.inputs(), before)
    memory.note(L)  # a pivot's frame adds nothing: the side is the original's own window
    memory.see(_values(STRIP))
    assert memory.inputs()[3] == 1.0


TURN = FreshFeltConfig(branch_side=True, branch_window="commands", branch_turn=True)


def test_the_turn_setting_adds_a_fifth_input_and_needs_the_side():
    assert TURN.n_inputs == 5 and policy_inputs(TURN, "none") == 5
    with pytest.raises(ValueError, match="branch_turn needs branch_side"):
        FreshFeltConfig(branch_turn=True)
    frames = [STRIP] * 5 + [LEFT_BRANCH] * 6 + [STRIP] * 4
    side_only = FreshFeltConfig(branch_side=True, branch_window="commands")
    four = _drive(FreshFeltMemory(side_only), frames)
    five = _drive(FreshFeltMemory(TURN), frames)
    for without, with_ in zip(four, five, strict=True):
        assert with_.shape == (5,)
        np.testing.assert_array_equal(with_[:4], without)  # the other inputs, the same bits
        assert with_[4] == UNKNOWN  # driving straight: no turn, side or not


def test_the_turn_input_counts_pivots_toward_the_side_since_it_was_set():
    pivot = 22.9
    assert BranchSide("commands", pivot).turned() == UNKNOWN  # nothing seen: no side, no turn
    side, value = _seen_left("commands")
    assert value == 1.0 and side.turned() == 0.5  # set now: no turn yet
    expected = [0.5 + k * pivot / 360.0 for k in (1, 2, 3)]
    for want in expected:
        side.moved(L)  # toward the side; a pivot's frame adds nothing
        assert _see(side) == 1.0
        assert side.turned() == pytest.approx(want)
    side.moved(R)  # back the other way: less turned toward it
    assert _see(side) == 1.0 and side.turned() == pytest.approx(expected[1])
    for _ in range(6):  # away, past where it was set
        side.moved(R)
        _see(side)
    assert side.turned() == pytest.approx(0.5 - 4 * pivot / 360.0)
    for _ in range(WINDOW_FORWARD):  # the side expires: no turn
        side.moved(R)
        _see(side)
    assert (_see(side), side.turned()) == (UNKNOWN, UNKNOWN)
    side.reset()
    assert side.turned() == UNKNOWN


def test_the_turn_input_is_clipped_and_a_new_side_starts_it_again():
    side, _ = _seen_left("forward")  # "forward": the side never expires while pivoting
    for _ in range(12):  # 275 degrees toward it
        side.moved(L)
        _see(side)
    assert side.turned() == 1.0
    mirrored = MAP_POINTS * [1.0, -1.0]  # felt branching off to the right now
    for _ in range(WINDOW_FORWARD + 1):  # the left frames leave the window, the right come in
        side.moved(F)
        value = side.see(mirrored, np.ones(len(mirrored)), MAP_PATH, len(mirrored))
    assert value == 0.0 and side.turned() == 0.5


def test_the_mirror_image_keeps_the_turn_toward_the_side():
    inputs = np.array([[0.7, 0.3, 0.2, 1.0, 0.8], [0.4, 0.1, 0.5, 0.0, 0.6]])
    mirrored = TURN.mirror(inputs)
    np.testing.assert_allclose(mirrored[:, 3], [0.0, 1.0])
    np.testing.assert_allclose(mirrored[:, 4], inputs[:, 4])
    # a left corner turned a quarter to the left is its mirror turned a quarter to the right
    left, right = BranchSide("commands"), BranchSide("commands")
    left.moved(F), right.moved(F)
    assert _see(left) == 1.0
    flipped = MAP_POINTS * [1.0, -1.0]
    assert right.see(flipped, np.ones(len(flipped)), MAP_PATH, len(flipped)) == 0.0
    for _ in range(4):
        left.moved(L), right.moved(R)
        _see(left)
        right.see(flipped, np.ones(len(flipped)), MAP_PATH, len(flipped))
    assert left.turned() == right.turned() > 0.5


def test_a_controller_reads_the_fifth_input_and_its_file_records_the_setting(tmp_path):
    _saved_and_loaded(tmp_path, TURN, 5)


def test_the_turn_from_the_newest_frame_that_saw_the_branch_restarts_while_driving_on():
    """``branch_turn_from = "seen"``: the turn counts from the newest frame in the window whose
    felt branched off on the side's side; "set" counts from the frame that set the side."""
    pivot = 22.9
    seen, since_set = BranchSide("commands", pivot, "seen"), BranchSide("commands", pivot)
    for side in (seen, since_set):
        side.moved(F)
        assert _see(side) == 1.0
        for _ in range(2):  # two pivots toward it: a pivot's frame adds nothing
            side.moved(L)
            _see(side)
        assert side.turned() == pytest.approx(0.5 + 2 * pivot / 360.0)
        side.moved(F)  # a step on, and the branch seen again from the new heading
        _see(side)
    assert seen.turned() == 0.5  # counted again from the frame that saw it last
    assert since_set.turned() == pytest.approx(0.5 + 2 * pivot / 360.0)  # still from the set
    with pytest.raises(ValueError, match="turn_from"):
        BranchSide("commands", pivot, "later")
    with pytest.raises(ValueError, match="branch_turn_from is a setting of branch_turn"):
        FreshFeltConfig(branch_side=True, branch_turn_from="seen")
    config = FreshFeltConfig(branch_side=True, branch_turn=True, branch_turn_from="seen")
    assert memory_config({"kind": "fresh_felt", **config.to_dict()}) == config
    assert FreshFeltMemory(config)._branch.turn_from == "seen"
