"""``room = "per_repetition"``: one world drawn per repetition from a randomized preset and kept
for its demonstration, learning and trials; ``"per_episode"`` (the default) as before."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any

import pytest

from lfd_track.benchmark import runner
from lfd_track.benchmark.config import BenchmarkConfig, config_dict
from lfd_track.benchmark.runner import repetition_preset, repetition_seeds
from lfd_track.benchmark.schema import RESULTS_SCHEMA, migrate_results
from lfd_track.envs.presets import Preset, load_preset
from lfd_track.envs.track_env import LfDTrackEnv
from lfd_track.errors import DemonstrationUnfinished
from lfd_track.methods import MethodContext, get_method
from lfd_track.policy.map_geometry import MapGeometry
from lfd_track.study.jobs import expected_config
from lfd_track.study.spec import load_study

ROOM = BenchmarkConfig(preset="randomized", room="per_repetition", repetitions=2)


def _world(preset: Preset) -> tuple[Any, ...]:
    return (
        preset.camera.height_m,
        preset.camera.pitch_deg,
        preset.appearance.felt_rgb,
        preset.lighting.ambient,
        preset.rover.slip_noise_std,
    )


def test_one_world_per_repetition_drawn_from_its_own_stream() -> None:
    seeds = repetition_seeds(ROOM.seed, 2)
    rooms = [repetition_preset(ROOM, s) for s in seeds]
    assert all(isinstance(r, Preset) and not r.randomized for r in rooms)
    assert _world(rooms[0]) != _world(rooms[1])  # two repetitions, two rooms
    assert repetition_preset(ROOM, seeds[0]) == rooms[0]  # the same seed, the same room
    ranges = {(r.section, r.key): r for r in load_preset("randomized").randomization}
    low, high = ranges["camera", "height_m"].low[0], ranges["camera", "height_m"].high[0]
    assert all(low <= r.camera.height_m <= high for r in rooms)  # type: ignore[union-attr]


def test_per_episode_and_unrandomized_presets_are_unchanged() -> None:
    seed = repetition_seeds(0, 1)[0]
    assert repetition_preset(dataclasses.replace(ROOM, room="per_episode"), seed) == "randomized"
    assert repetition_preset(BenchmarkConfig(room="per_repetition"), seed) == "paper"
    assert BenchmarkConfig().room == "per_episode"
    with pytest.raises(ValueError, match="room must be one of"):
        BenchmarkConfig(room="per_lap")


def test_every_episode_of_the_room_sees_the_same_world() -> None:
    room = repetition_preset(ROOM, repetition_seeds(0, 1)[0])
    assert isinstance(room, Preset)
    kept = LfDTrackEnv(track="testing", preset=room)
    redrawn = LfDTrackEnv(track="testing", preset="randomized")
    try:
        seen, drawn = set(), set()
        for seed in (1, 2, None):
            kept.reset(seed=seed)
            redrawn.reset(seed=seed)
            seen.add(_world(kept.preset))
            drawn.add(_world(redrawn.preset))
        assert seen == {_world(room)}
        assert len(drawn) == 3  # the preset as it is: a new room every episode
    finally:
        kept.close()
        redrawn.close()


def test_the_maps_geometry_is_the_rooms(tmp_path: Path) -> None:
    room = repetition_preset(ROOM, repetition_seeds(0, 1)[0])
    assert isinstance(room, Preset)
    geometry = MapGeometry.from_preset(room)
    assert geometry != MapGeometry.from_preset(load_preset("randomized"))
    seen: list[MethodContext] = []

    def learn(context: MethodContext) -> Any:
        seen.append(context)
        raise DemonstrationUnfinished("stop here")

    method = dataclasses.replace(get_method("paper"), learn=learn)
    with pytest.raises(DemonstrationUnfinished):
        runner.learn_repetition(ROOM, tmp_path, demo_seed=1, ga_seed=2, method=method, preset=room)
    assert seen[0].preset == room and seen[0].map_geometry == geometry
    env = LfDTrackEnv(track="testing", preset=room)
    try:  # run_trial builds the map of the env's world
        assert MapGeometry.from_preset(env.base_preset) == geometry
    finally:
        env.close()


def test_the_repetition_teaches_and_drives_in_its_room(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    taught: list[Any] = []
    driven: list[Any] = []

    def learn(*args: Any, preset: Any = None, **kwargs: Any) -> Any:
        taught.append(preset)
        raise DemonstrationUnfinished("the teacher got lost")

    class Env(LfDTrackEnv):
        def __init__(self, *args: Any, preset: Any = "paper", **kwargs: Any) -> None:
            driven.append(preset)
            super().__init__(*args, preset=preset, **kwargs)

    monkeypatch.setattr(runner, "learn_repetition", learn)
    monkeypatch.setattr(runner, "LfDTrackEnv", Env)
    seed = repetition_seeds(0, 1)[0]
    config = dataclasses.replace(ROOM, trials_per_direction=1)
    result = runner.run_repetition(0, seed, config, str(tmp_path))
    assert result.failed == "the teacher got lost"
    room = repetition_preset(config, seed)
    assert taught == [room] and driven and all(p == room for p in driven)


def test_room_round_trips_through_results_and_study(tmp_path: Path) -> None:
    data = config_dict(ROOM)
    assert data["room"] == "per_repetition"
    assert "room" not in config_dict(BenchmarkConfig())  # absent means per_episode
    stored = json.loads(json.dumps({"schema": RESULTS_SCHEMA, "config": data}))
    assert BenchmarkConfig.from_dict(migrate_results(stored, "results.json")["config"]) == ROOM
    assert BenchmarkConfig.from_dict({}).room == "per_episode"
    study = tmp_path / "study.toml"
    study.write_text(
        '[study]\nschema = 3\nseeds = [0]\nrepetitions = 1\n\n[defaults]\npreset = "randomized"\n'
        'room = "per_repetition"\n\n[[conditions]]\nname = "room"\nmethod = "paper"\n'
    )
    (job,) = load_study(study).jobs()
    assert job.config.room == "per_repetition"
    assert expected_config(job)["room"] == "per_repetition"


@pytest.mark.parametrize(
    ("preset", "scale"),
    [
        ("randomized_fast", 0.5),
        (
            str(
                Path(__file__).resolve().parents[2]
                / "benchmarks/experiments/human_goal/round29/presets/randomized_quarter.toml"
            ),
            0.25,
        ),
    ],
)
def test_the_smaller_cameras_rooms_are_the_full_cameras_rooms(preset: str, scale: float) -> None:
    # randomized_fast (and round 29's quarter camera) draw the same rooms from the same seeds;
    # only the frames are smaller.
    smaller = dataclasses.replace(ROOM, preset=preset)
    for seed in repetition_seeds(0, 3):
        full, small = repetition_preset(ROOM, seed), repetition_preset(smaller, seed)
        assert isinstance(full, Preset) and isinstance(small, Preset)
        assert small.camera.scale == scale and full.camera.scale == 1.0
        same = dataclasses.replace(small, name=full.name, source=full.source)
        same = dataclasses.replace(same, camera=dataclasses.replace(small.camera, scale=1.0))
        assert same == full
