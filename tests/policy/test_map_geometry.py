"""The fresh-felt map's geometry comes from the world it is taught in (camera and motion), the
controller records it, and driving where it differs says so in one line."""

import dataclasses
import json
import math
from pathlib import Path

import numpy as np
import pytest
from lfd_test_support import library_with_road

from lfd_track.benchmark.config import BenchmarkConfig
from lfd_track.benchmark.schema import migrate_results
from lfd_track.core.camera_model import CameraModel
from lfd_track.core.commands import Command
from lfd_track.core.frame import GRID_COLUMNS, GRID_ROWS, N_REGIONS, region_bounds
from lfd_track.envs.presets import load_preset
from lfd_track.policy.controller import Controller
from lfd_track.policy.controller_schema import checksum
from lfd_track.policy.map_geometry import (
    PAPER_GEOMETRY,
    TOLERANCES,
    MapGeometry,
    hardware_geometry,
)
from lfd_track.policy.memory import (
    PIVOT_DEG,
    STEP_M,
    FreshFeltConfig,
    FreshFeltMemory,
    fresh_bearing_rad,
    region_floor_points,
)
from lfd_track.policy.mlp import n_weights
from lfd_track.study.spec import load_study
from lfd_track.teaching.perception import Perception

REPO = Path(__file__).resolve().parents[2]
CHOSEN = REPO / "benchmarks" / "experiments" / "goal" / "distilled.toml"
STORED = (
    REPO / "benchmarks/experiments/goal/round07/results/selection_round7"
    / "hg-dagger.r1+fresh.last+picture/seed0/results.json"
)  # fmt: skip
#: The map with every option off, its bearing over the whole circle, no visited felt: the felt
#: seen stays on the map wherever the rover went.
OPEN = FreshFeltConfig.plain(path_radius_m=0.0, geometry="world")


def _centres(width: int = 640, height: int = 480) -> np.ndarray:
    bounds = np.array([region_bounds(i, width, height) for i in range(N_REGIONS)], dtype=float)
    return (bounds[:, :2] + bounds[:, 2:] - 1.0) / 2.0


def _values(columns: set[int], rows: set[int]) -> np.ndarray:
    grid = np.zeros((GRID_ROWS, GRID_COLUMNS))
    for r in rows:
        for c in columns:
            grid[r, c] = 1.0
    return grid.reshape(N_REGIONS)


def _preset_with(name: str = "paper", **rover: float):
    preset = load_preset(name)
    return dataclasses.replace(preset, rover=dataclasses.replace(preset.rover, **rover))


def test_the_paper_constants_are_the_old_map_and_the_paper_preset_is_within_tolerance():
    assert (PAPER_GEOMETRY.step_m, PAPER_GEOMETRY.pivot_deg) == (STEP_M, PIVOT_DEG) == (0.10, 22.9)
    paper = MapGeometry.from_preset(load_preset("paper"))
    assert paper.step_m == pytest.approx(0.25 * 0.4, abs=1e-15)
    assert paper.pivot_deg == pytest.approx(math.degrees(0.4), abs=1e-12)  # 22.918 deg
    assert paper.camera() == dataclasses.replace(
        load_preset("paper").camera, texture_filter="mipmap"
    )
    assert PAPER_GEOMETRY.differences(paper) == []
    # the floor points of the world's geometry under the paper preset are today's
    today = CameraModel().floor_points(_centres(), np.zeros(3))
    np.testing.assert_allclose(paper.floor_points(), today, rtol=0, atol=1e-12)
    np.testing.assert_allclose(region_floor_points(), today, rtol=0, atol=1e-12)


def test_the_map_under_wide_places_the_regions_with_the_fisheye():
    wide = load_preset("wide")
    geometry = MapGeometry.from_preset(wide)
    assert geometry.lens == "fisheye"
    perception = Perception(library_with_road()[0], "frozen", FreshFeltConfig(), geometry=geometry)
    assert perception.map_geometry == geometry
    memory = perception._memory
    assert isinstance(memory, FreshFeltMemory)
    camera = wide.camera
    expected = CameraModel(camera).floor_points(
        _centres(camera.frame_width_px, camera.frame_height_px), np.zeros(3)
    )
    np.testing.assert_allclose(memory._region_points, expected, rtol=0, atol=1e-12)
    assert np.abs(expected - region_floor_points()).max() > 0.05  # not the paper's pinhole
    # the same map with the paper's geometry ignores the world's
    paper = Perception(
        library_with_road()[0], "frozen", FreshFeltConfig(geometry="paper"), geometry=geometry
    )
    assert paper.map_geometry == PAPER_GEOMETRY
    # without a geometry given, the map has the paper's constants
    assert Perception(library_with_road()[0], "frozen", FreshFeltConfig()).map_geometry == (
        PAPER_GEOMETRY
    )


def test_the_map_moves_by_the_presets_own_step_and_pivot():
    geometry = MapGeometry.from_preset(_preset_with(forward_speed_mps=0.3, pivot_rate_radps=1.2))
    step, pivot = 0.3 * 0.4, math.degrees(1.2 * 0.4)
    assert geometry.step_m == pytest.approx(step) and geometry.pivot_deg == pytest.approx(pivot)
    reach = OPEN.reach_m
    # forward: felt straight ahead comes one step nearer
    memory = FreshFeltMemory(OPEN, geometry)
    memory.see(_values({3, 4}, {2}))
    before = memory.inputs()[2] * reach
    memory.note(Command.FORWARD)
    memory.see(np.zeros(N_REGIONS))
    assert before - memory.inputs()[2] * reach == pytest.approx(step, abs=1e-9)
    # a pivot turns the remembered felt the other way by the preset's pivot
    memory = FreshFeltMemory(OPEN, geometry)
    memory.see(_values({3, 4}, {2}))
    memory.note(Command.LEFT)
    memory.see(np.zeros(N_REGIONS))
    assert math.degrees(fresh_bearing_rad(memory.inputs())) == pytest.approx(-pivot, abs=1e-9)
    # place_before undoes the same motion
    memory.place_before(Command.LEFT)  # stands where the left pivot brought it from
    memory.see(np.zeros(N_REGIONS))
    assert math.degrees(fresh_bearing_rad(memory.inputs())) == pytest.approx(0.0, abs=1e-9)


def _controller(geometry: MapGeometry | None, memory: FreshFeltConfig) -> Controller:
    library = library_with_road()[0]
    weights = np.linspace(-1.0, 1.0, n_weights(False, N_REGIONS + 3))
    return Controller(library, weights, memory=memory, map_geometry=geometry)


def test_a_controller_records_its_geometry_and_driving_elsewhere_says_so_once(tmp_path, capsys):
    taught = MapGeometry.from_preset(_preset_with(pivot_rate_radps=1.1))
    path = tmp_path / "c.json"
    _controller(taught, FreshFeltConfig()).save(path)
    loaded = Controller.load(path)
    assert loaded.map_geometry == taught
    assert json.loads(path.read_text())["map_geometry"] == taught.to_dict()
    # the same world: nothing said
    perception = loaded.perception(world_geometry=taught)
    assert capsys.readouterr().err == ""
    # pivots 15 % faster, the phone 2 cm higher: one line naming both and the difference
    world = dataclasses.replace(taught, pivot_deg=taught.pivot_deg * 1.15, height_m=0.33)
    perception = loaded.perception(world_geometry=world)
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 1
    assert taught.describe() in lines[0] and world.describe() in lines[0]
    assert "pivot" in lines[0] and "+15.0 %" in lines[0] and "camera height" in lines[0]
    assert perception.map_geometry == taught  # it drives with what it was taught
    loaded.perception(world_geometry=world)
    assert capsys.readouterr().err == ""  # once per process and pair
    # within the tolerances: nothing said
    close = dataclasses.replace(
        taught,
        step_m=taught.step_m * (1 + 0.8 * TOLERANCES["step_m"]),
        pitch_deg=taught.pitch_deg + 0.5,
    )
    loaded.perception(world_geometry=close)
    assert capsys.readouterr().err == ""
    # a controller without the map records none and says nothing
    plain = Controller(library_with_road()[0], np.zeros(n_weights(False, N_REGIONS)))
    assert plain.map_geometry is None and plain.to_dict()["map_geometry"] is None
    plain.perception(world_geometry=world)
    assert capsys.readouterr().err == ""


def test_a_map_with_the_paper_geometry_records_the_paper_constants():
    taught = MapGeometry.from_preset(load_preset("wide"))
    assert _controller(taught, FreshFeltConfig(geometry="paper")).map_geometry == PAPER_GEOMETRY


def test_an_older_controller_file_loads_with_the_paper_constants(tmp_path):
    path = tmp_path / "c.json"
    _controller(MapGeometry.from_preset(load_preset("wide")), FreshFeltConfig()).save(path)
    data = json.loads(path.read_text())
    del data["map_geometry"]
    del data["memory"]["geometry"]
    data["schema_version"] = 6
    data["checksum"] = checksum(data)
    path.write_text(json.dumps(data))
    loaded = Controller.load(path)
    assert loaded.map_geometry == PAPER_GEOMETRY
    assert loaded.memory == FreshFeltConfig(geometry="paper")
    assert loaded.perception().map_geometry == PAPER_GEOMETRY


def test_committed_studies_and_results_keep_the_paper_geometry(tmp_path):
    chosen = load_study(CHOSEN, check_names=False).conditions[0].config.memory
    assert isinstance(chosen, FreshFeltConfig) and chosen.geometry == "paper"
    stored = json.loads(STORED.read_text())
    assert "geometry" not in stored["config"]["memory"]
    config = migrate_results(stored, STORED)["config"]
    assert config["memory"]["geometry"] == "paper"
    assert BenchmarkConfig.from_dict(config).memory.geometry == "paper"
    # a study file of today's schema means the world's geometry
    text = CHOSEN.read_text()
    assert "schema = 2" in text
    new = tmp_path / "chosen.toml"
    new.write_text(text.replace("schema = 2", "schema = 3", 1))
    assert load_study(new, check_names=False).conditions[0].config.memory.geometry == "world"


def test_geometry_files_and_the_robots_geometry():
    wide = MapGeometry.from_preset(load_preset("wide"))
    assert MapGeometry.from_dict(json.loads(json.dumps(wide.to_dict()))) == wide
    with pytest.raises(ValueError, match="unknown map geometry key 'tilt'"):
        MapGeometry.from_dict({**wide.to_dict(), "tilt": 1.0})
    with pytest.raises(ValueError, match="pivot_deg"):
        MapGeometry(pivot_deg=0.0)
    # no profile: the paper preset's camera and rates, at the robot's control period
    assert hardware_geometry() == MapGeometry.from_preset(load_preset("paper"))
    assert hardware_geometry(period_s=0.5).step_m == pytest.approx(0.25 * 0.5)
    assert hardware_geometry(wide) is wide


def test_the_strip_seed_ring_reaches_the_nearest_row_of_any_camera():
    """The felt the rover stands on is looked for within 0.3 m under the paper's camera (its map
    unchanged), and further out for a camera whose nearest row looks further ahead."""
    from lfd_track.policy.memory import _STRIP_SEED_M, _strip_seed_m

    assert _strip_seed_m(PAPER_GEOMETRY.floor_points()) == _STRIP_SEED_M
    steep = dataclasses.replace(PAPER_GEOMETRY, pitch_deg=36.0)
    flat = dataclasses.replace(PAPER_GEOMETRY, pitch_deg=26.0, height_m=0.33)
    assert _strip_seed_m(steep.floor_points()) == _STRIP_SEED_M
    points = flat.floor_points()
    nearest = float(np.hypot(points[:, 0], points[:, 1]).min())
    assert nearest > _STRIP_SEED_M
    assert _strip_seed_m(points) > nearest
