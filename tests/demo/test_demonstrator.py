"""The scripted human and the demonstration protocol meet the calibration targets in its docstring."""

from __future__ import annotations

import numpy as np
import pytest

from lfd_track.dataset import load_demonstration
from lfd_track.demo.demonstrator import HumanConfig, run_demonstration


@pytest.fixture(scope="module")
def default_demo(tmp_path_factory):
    path = tmp_path_factory.mktemp("demo") / "d.lfdemo"
    summary = run_demonstration(path, seed=3, fsync=False)
    return summary, load_demonstration(path)


def test_default_demonstration_meets_the_calibration_targets(default_demo):
    summary, demo = default_demo
    assert 120 <= demo.n_cases <= 200
    assert summary.library_models >= 40
    counts = demo.command_counts
    assert counts["forward"] > demo.n_cases / 2
    assert summary.turnarounds == ("left", "right", "left", "right")
    assert summary.learned_off_felt == 0
    assert (
        summary.off_felt_frames > 0
    )  # the box did leave the felt (turn-arounds): the pause mattered
    # No case marked as learned was recorded with the box off the felt.
    assert demo.metadata["complete"] is True
    assert demo.metadata["road_library"]["bins"] == demo.bins


def test_library_only_commands_are_not_recorded_and_turnarounds_are(default_demo):
    summary, demo = default_demo
    assert summary.commands == demo.n_cases + 10
    assert demo.steps[0] == 10
    phases = set(demo.phases.tolist())
    assert phases == {"drive", "turnaround"}
    turn_cmds = demo.commands[demo.phases == "turnaround"]
    assert set(turn_cmds.tolist()) == {1, 2}
    # As many left as right turn-around commands, within one turn-around's worth.
    assert abs(int((turn_cmds == 1).sum()) - int((turn_cmds == 2).sum())) <= 4


def test_record_time_values_come_from_the_stored_histograms(default_demo):
    from lfd_track.vision.road_library import RoadLibrary

    _, demo = default_demo
    assert demo.road_values.shape == (demo.n_cases, 40)
    assert demo.histograms.shape == (demo.n_cases, 40, 5, 32)
    # After the last case nothing more was learned, so the stored final library reproduces the
    # last case's record-time values from its stored histograms.
    library = RoadLibrary.from_dict(demo.metadata["road_library"])
    last = library.road_values_from_histograms(demo.histograms[-1], update_statistics=False)
    np.testing.assert_allclose(last, demo.road_values[-1], atol=1e-9)
    # Earlier cases were recorded with a younger library: not all of them match the final one.
    first = library.road_values_from_histograms(demo.histograms[0], update_statistics=False)
    assert not np.allclose(first, demo.road_values[0])


def test_learning_happened_only_with_the_safe_box_on_the_felt(default_demo):
    from lfd_track.core.camera_model import CameraModel
    from lfd_track.world.track import load_track

    _, demo = default_demo
    track = load_track("training")
    camera = CameraModel()
    box_on_felt = np.array(
        [bool(track.on_felt(camera.safe_box_floor_polygon(pose)).all()) for pose in demo.poses]
    )
    assert demo.learned.any() and (~box_on_felt).any()
    # Recomputed independently from the stored poses: no learning with the box off the felt.
    assert not (demo.learned & ~box_on_felt).any()
    assert (demo.learned == box_on_felt).all()


def test_careless_demonstrator_learns_carpet(tmp_path):
    summary = run_demonstration(
        tmp_path / "careless.lfdemo", seed=3, human=HumanConfig(careful=False), fsync=False
    )
    assert summary.learned_off_felt > 0


def test_same_seed_same_demonstration(tmp_path):
    a = run_demonstration(tmp_path / "a.lfdemo", seed=5, fsync=False)
    b = run_demonstration(tmp_path / "b.lfdemo", seed=5, fsync=False)
    da, db = load_demonstration(tmp_path / "a.lfdemo"), load_demonstration(tmp_path / "b.lfdemo")
    assert a.n_cases == b.n_cases
    assert np.array_equal(da.commands, db.commands)
    assert np.array_equal(da.road_values, db.road_values)


def test_human_traits_are_validated():
    with pytest.raises(ValueError, match="lapse_prob"):
        HumanConfig(lapse_prob=1.5)
    with pytest.raises(ValueError, match="first_turnaround"):
        HumanConfig(first_turnaround="up")


def test_on_a_loop_each_leg_is_a_lap_and_the_next_goes_the_other_way(tmp_path):
    # random:train:27 is a 2.9 m loop: two legs are a lap each way, each ending in a turn-around
    # (as every leg of the protocol does).
    from lfd_track.world.track import load_track

    track = "random:train:27"
    human = HumanConfig(legs=2)
    summary = run_demonstration(
        tmp_path / "loop.lfdemo", seed=0, track=track, human=human, fsync=False
    )
    demo = load_demonstration(tmp_path / "loop.lfdemo")
    assert summary.turnarounds == ("left", "right")
    phases = np.asarray(demo.phases)
    turning = phases == "turnaround"
    # Two drives, each followed by its turn-around: drive, turn, drive, turn.
    runs = [phases[0]] + [p for q, p in zip(phases[:-1], phases[1:], strict=True) if p != q]
    assert runs == ["drive", "turnaround", "drive", "turnaround"]
    first_turn = int(np.argmax(turning))
    second_leg = first_turn + int(np.argmax(~turning[first_turn:]))
    length = load_track(track).length_m
    # Each leg ends stop_before_end_m short of a whole lap of its own direction.
    for leg in (slice(0, first_turn), slice(second_leg, None)):
        progress = demo.progress_m[leg][phases[leg] == "drive"]
        assert progress.max() == pytest.approx(length - human.stop_before_end_m, abs=0.15)
    # The turn-around faces the rover the other way round the loop.
    before, after = demo.poses[first_turn - 1, 2], demo.poses[second_leg, 2]
    assert np.cos(after - before) < 0.0
    assert summary.commands <= 2 * (length / 0.1) + 80


class _FixedDriver:
    """Stands in for the centreline driver: answers a scripted sequence of commands."""

    def __init__(self, commands):
        self.commands = list(commands)

    def act(self, pose, progress_m):
        return self.commands.pop(0)


def _decide_all(config, intended, seed=0):
    from lfd_track.demo.demonstrator import ScriptedHuman

    human = ScriptedHuman(config, np.random.default_rng(seed))
    driver = _FixedDriver(intended)
    return [human.decide(driver, np.zeros(3), 0.0) for _ in intended]


def test_reaction_delay_answers_the_previous_frame():
    from lfd_track.core.commands import Command as C

    calm = HumanConfig(reaction_delay_prob=0.0, lapse_prob=0.0)
    late = HumanConfig(reaction_delay_prob=1.0, lapse_prob=0.0)
    intended = [C.FORWARD, C.LEFT, C.FORWARD, C.FORWARD, C.RIGHT, C.FORWARD]
    assert _decide_all(calm, intended) == intended
    assert _decide_all(late, intended) == [
        C.FORWARD,
        C.FORWARD,
        C.LEFT,
        C.FORWARD,
        C.FORWARD,
        C.RIGHT,
    ]


def test_lapses_repeat_the_last_command():
    from lfd_track.core.commands import Command as C

    lapsing = HumanConfig(reaction_delay_prob=0.0, lapse_prob=1.0)
    intended = [C.LEFT, C.FORWARD, C.RIGHT, C.FORWARD]
    assert _decide_all(lapsing, intended) == [C.FORWARD] * 4  # starts on forward, never lets go


def test_never_left_straight_after_right():
    from lfd_track.core.commands import Command as C

    calm = HumanConfig(reaction_delay_prob=0.0, lapse_prob=0.0)
    intended = [C.LEFT, C.RIGHT, C.RIGHT, C.LEFT, C.FORWARD, C.LEFT]
    assert _decide_all(calm, intended) == [C.LEFT, C.FORWARD, C.RIGHT, C.FORWARD, C.FORWARD, C.LEFT]
    noisy = HumanConfig(reaction_delay_prob=0.3, lapse_prob=0.2)
    rng = np.random.default_rng(4)
    sequence = [C(int(c)) for c in rng.integers(0, 3, 500)]
    out = _decide_all(noisy, sequence, seed=5)
    assert all({a, b} != {C.LEFT, C.RIGHT} for a, b in zip(out, out[1:], strict=False))
