"""The ``fresh_felt`` map's felt levels: fixed, or read from the road values the library gave in
its world (``felt_levels = "library"``, :mod:`lfd_track.vision.felt_levels`)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from lfd_track.core.commands import Command
from lfd_track.envs.presets import load_preset
from lfd_track.envs.track_env import LfDTrackEnv
from lfd_track.policy.controller import Controller
from lfd_track.policy.memory import (
    CARPET_LEVEL,
    FELT_LEVEL,
    FreshFeltConfig,
    FreshFeltMemory,
    memory_config,
    memory_table_from_v1,
    policy_inputs,
)
from lfd_track.study.spec import load_study
from lfd_track.teaching.perception import Perception
from lfd_track.vision.felt_levels import LEVEL_RAMP_WIDTH, MIN_FRAMES, RoadValueLevels
from lfd_track.vision.road_library import RoadLibrary
from lfd_track.world.driver import CentrelineDriver

#: [road value] how close the library's levels come to the fixed ones in the paper world.
PAPER_TOLERANCE = 0.06


def _frames(rng: np.random.Generator, carpet_mean: float, n: int = 30) -> list[np.ndarray]:
    """Road values of ``n`` frames: 12 felt regions near 0.9, 28 carpet near ``carpet_mean``."""
    frames = []
    for _ in range(n):
        felt = rng.normal(0.9, 0.04, 12)
        carpet = rng.normal(carpet_mean, 0.06, 28)
        frames.append(np.clip(np.concatenate([felt, carpet]), -1.0, 1.0))
    return frames


def _levels_after(frames: list[np.ndarray]) -> tuple[float, float] | None:
    levels = RoadValueLevels()
    for values in frames:
        levels.add(values)
    return levels.levels()


def test_levels_move_with_the_carpet_values():
    rng = np.random.default_rng(0)
    dull = _levels_after(_frames(rng, 0.10))
    bright = _levels_after(_frames(rng, 0.25))
    assert dull is not None and bright is not None
    assert bright[0] - dull[0] == pytest.approx(0.15, abs=0.03)
    for carpet, felt in (dull, bright):
        assert felt - carpet == pytest.approx(LEVEL_RAMP_WIDTH)


def test_no_levels_before_enough_frames_or_without_two_parts():
    rng = np.random.default_rng(1)
    frames = _frames(rng, 0.1)
    assert _levels_after(frames[: MIN_FRAMES - 1]) is None
    assert _levels_after(frames[:MIN_FRAMES]) is not None
    only_felt = [rng.normal(0.9, 0.05, 40) for _ in range(20)]  # a view of felt alone
    assert _levels_after(only_felt) is None
    assert _levels_after([]) is None


def test_a_long_view_of_carpet_alone_keeps_the_last_clear_levels():
    # A rover that has lost the strip and turns on the spot sees carpet alone for longer than
    # the histogram remembers; the carpet's own spread (here 0.05-0.5, as in a greenish room)
    # must not become a felt-versus-carpet split that puts felt inside the carpet's values.
    rng = np.random.default_rng(3)
    levels = RoadValueLevels()
    for values in _frames(rng, 0.25):
        levels.add(values)
    clear = levels.levels()
    assert clear is not None
    for _ in range(200):
        levels.add(np.concatenate([rng.uniform(0.0, 0.15, 20), rng.uniform(0.35, 0.5, 20)]))
    assert levels.levels() == clear
    for values in _frames(rng, 0.10, 150):  # felt again, over a duller carpet: the levels follow
        levels.add(values)
    after = levels.levels()
    assert after is not None and after[0] < clear[0] - 0.05


def test_looking_at_the_levels_changes_nothing():
    levels = RoadValueLevels()
    for values in _frames(np.random.default_rng(2), 0.1, 10):
        levels.add(values)
    first = levels.levels()
    assert levels.levels() == first and levels.frames == 10


def _lap_levels(preset, steps: int = 40) -> tuple[float, float] | None:
    """The library levels after the centreline teacher's first ``steps`` commands of the testing
    track, learning carefully from an empty library (as a demonstration does)."""
    env = LfDTrackEnv(track="testing", preset=preset)
    obs, info = env.reset(seed=0)
    driver = CentrelineDriver(env.track)
    perception = Perception(RoadLibrary(), "careful", FreshFeltConfig(felt_levels="library"))
    for _ in range(steps):
        perception.perceive(obs, info["safe_box_on_felt"])
        command = driver.act(np.asarray(info["pose"]), info["progress_m"])
        obs, _, terminated, truncated, info = env.step(int(command))
        if terminated or truncated:
            break
    assert perception.felt_levels is not None
    return perception.felt_levels.levels()


@pytest.fixture(scope="module")
def paper_levels():
    return _lap_levels("paper")


def test_library_levels_in_the_paper_world_are_close_to_the_fixed_ones(paper_levels):
    assert paper_levels is not None
    carpet, felt = paper_levels
    assert carpet == pytest.approx(CARPET_LEVEL, abs=PAPER_TOLERANCE)
    assert felt == pytest.approx(FELT_LEVEL, abs=PAPER_TOLERANCE)


def test_library_levels_rise_in_a_room_whose_carpet_looks_more_like_felt(paper_levels):
    # Room 0 of the robustness measurement: a greenish carpet whose road values reach 0.45.
    randomized = load_preset("randomized")
    room = dataclasses.replace(
        randomized.sample(np.random.default_rng(0)), name="room0", randomization=()
    )
    levels = _lap_levels(room, steps=100)  # a lap: the carpet of the corners seen too
    assert levels is not None and paper_levels is not None
    assert levels[0] > paper_levels[0] + 0.08  # 0.45 against 0.32


def test_fixed_levels_give_the_map_the_inputs_it_had_before_the_setting():
    config = FreshFeltConfig()
    assert config.felt_levels == "fixed"
    assert FreshFeltConfig.plain().felt_levels == "fixed"
    env = LfDTrackEnv(track="testing")
    obs, info = env.reset(seed=0)
    driver = CentrelineDriver(env.track)
    perception = Perception(RoadLibrary(), "careful", config)
    assert perception.felt_levels is None
    direct = FreshFeltMemory(config)  # the map fed as before the setting: see(values)
    passed = FreshFeltMemory(config)  # the fixed levels passed explicitly
    for _ in range(15):
        percept = perception.perceive(obs, info["safe_box_on_felt"])
        direct.see(percept.values)
        passed.see(percept.values, (CARPET_LEVEL, FELT_LEVEL))
        assert percept.memory.tobytes() == direct.inputs().tobytes() == passed.inputs().tobytes()
        # the felt levels are the formula of the map before the setting, bit for bit
        before = np.clip((percept.values - 0.3) / (0.5 - 0.3), 0.0, 1.0)
        assert direct._felt[-40:].tobytes() == before.tobytes()
        command = driver.act(np.asarray(info["pose"]), info["progress_m"])
        perception.note(command)
        direct.note(command)
        passed.note(command)
        obs, *_, info = env.step(int(command))


def test_library_levels_reach_the_map_through_the_perception():
    config = FreshFeltConfig(felt_levels="library")
    library = RoadLibrary()
    library.learn_model(np.full((5, library.bins), 1.0 / library.bins))
    perception = Perception(library, "frozen", config)
    assert perception.felt_levels is not None
    frame = np.zeros((480, 640, 3), dtype=np.uint8)
    perception.perceive(frame)
    assert perception.felt_levels.frames == 1  # a library with models: the frame counts
    perception.look(frame)
    perception.view(frame, Command.FORWARD)
    assert perception.felt_levels.frames == 1  # looking and views add nothing
    empty = Perception(RoadLibrary(), "careful", config)
    empty.perceive(frame, box_on_felt=False)  # nothing learned: the zeros say nothing
    assert empty.felt_levels is not None and empty.felt_levels.frames == 0


def test_the_setting_round_trips_through_tables_and_is_checked():
    config = memory_config({"kind": "fresh_felt", "felt_levels": "library"})
    assert isinstance(config, FreshFeltConfig) and config.felt_levels == "library"
    assert memory_config(config.to_dict()) == config
    assert config.to_dict()["felt_levels"] == "library"
    # a table written before the setting existed meant the fixed levels
    old = {k: v for k, v in FreshFeltConfig().to_dict().items() if k != "felt_levels"}
    assert memory_table_from_v1(old)["felt_levels"] == "fixed"
    with pytest.raises(ValueError, match="felt_levels"):
        memory_config({"kind": "fresh_felt", "felt_levels": "otsu"})


def test_the_setting_round_trips_through_a_controller_file(tmp_path):
    config = FreshFeltConfig(felt_levels="library")
    library = RoadLibrary()
    library.learn_model(np.full((5, library.bins), 1.0 / library.bins))
    n = policy_inputs(config, "none") * 5 + 5 * 3
    controller = Controller(library, np.zeros(n), memory=config, features="none")
    path = tmp_path / "controller.json"
    controller.save(path)
    loaded = Controller.load(path)
    assert loaded.memory == config
    assert loaded.perception().felt_levels is not None


def test_the_setting_round_trips_through_a_study_file(tmp_path):
    study = tmp_path / "levels.toml"
    study.write_text(
        '[study]\nschema = 2\nname = "levels"\nseeds = [0]\nrepetitions = 1\n\n'
        '[[conditions]]\nname = "library"\nmethod = "bc"\nfeatures = "none"\n'
        '[conditions.memory]\nkind = "fresh_felt"\nfelt_levels = "library"\n',
        encoding="utf-8",
    )
    memory = load_study(study).conditions[0].config.memory
    assert isinstance(memory, FreshFeltConfig) and memory.felt_levels == "library"
