"""Visual odometry on the floor: the motion between two frames, measured against the simulated
rover's true pose, and refused where the floor gives nothing to match."""

import math
from functools import cache
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import lfd_track  # noqa: F401  (registers the env)
from lfd_track.envs.presets import load_preset
from lfd_track.policy.map_geometry import PAPER_GEOMETRY, MapGeometry
from lfd_track.policy.memory import FreshFeltConfig, FreshFeltMemory
from lfd_track.policy.odometry import FloorOdometry, PlanarMotion

ROOT = Path(__file__).resolve().parents[2]
SLIP = "benchmarks/experiments/robustness/presets/slip.toml"
NOMINAL = {
    0: PlanarMotion(0.10, 0.0, 0.0),
    1: PlanarMotion(0.0, 0.0, 22.9),
    2: PlanarMotion(0.0, 0.0, -22.9),
}


def _preset_path(preset: str) -> str:
    """A preset's name, or the path of a preset file of the repository."""
    return str(ROOT / preset) if preset.endswith(".toml") else preset


@cache
def _drive(preset: str) -> list[tuple[np.ndarray, np.ndarray, int, PlanarMotion]]:
    """Frames before and after each of six commands on the training track's first strip (two
    forward, a left, a right, two forward), with the true motion of each."""
    env = gym.make("LfDTrack-v0", track="training", preset=_preset_path(preset))
    frame, info = env.reset(seed=3)
    out = []
    for command in (0, 0, 1, 2, 0, 0):
        after, _, _, _, after_info = env.step(command)
        out.append(
            (frame, after, command, PlanarMotion.from_poses(info["pose"], after_info["pose"]))
        )
        frame, info = after, after_info
    env.close()
    return out


@pytest.mark.parametrize(
    ("registration", "turn_deg", "shift_m"),
    [("full", 0.5, 0.01), ("quick", 0.5, 0.01), ("coarse", 1.5, 0.02)],
)
@pytest.mark.parametrize("preset", ["paper", SLIP])
def test_the_motion_between_frames_matches_the_true_one(
    preset: str, registration: str, turn_deg: float, shift_m: float
) -> None:
    # Every command's turn within 0.5 deg and its shift within 1 cm of the rover's true motion
    # (the coarse fit alone: 1.5 deg and 2 cm), where the nominal motion is further off (slip: a
    # forward command turns the rover too).
    odometry = FloorOdometry(PAPER_GEOMETRY, registration)
    nominal_turn_errors = []
    for before, after, command, truth in _drive(preset):
        found = odometry.between(before, after, NOMINAL[command])
        assert found.reliable, (command, found)
        assert found.motion.turn_deg == pytest.approx(truth.turn_deg, abs=turn_deg)
        assert found.motion.forward_m == pytest.approx(truth.forward_m, abs=shift_m)
        assert found.motion.left_m == pytest.approx(truth.left_m, abs=shift_m)
        nominal_turn_errors.append(abs(NOMINAL[command].turn_deg - truth.turn_deg))
    assert max(nominal_turn_errors) > 1.0  # the nominal motion is off by more than that


@pytest.mark.parametrize(
    ("registration", "fits", "iterations"), [("full", 6, 30), ("quick", 2, 15), ("coarse", 1, 15)]
)
def test_a_registration_fits_from_its_starts_with_its_iterations(
    monkeypatch: pytest.MonkeyPatch, registration: str, fits: int, iterations: int
) -> None:
    # A motion no start fits well (a bare floor and a shifted copy of the training track) runs
    # every start of the registration and then the fine fit (none for coarse), each with its
    # iteration cap.
    import cv2

    calls = []
    ecc = cv2.findTransformECC

    def counted(*args):
        calls.append(args[4][1])  # the criteria's iteration count
        return ecc(*args)

    monkeypatch.setattr(cv2, "findTransformECC", counted)
    before, after, _, _ = _drive("paper")[0]
    odometry = FloorOdometry(PAPER_GEOMETRY, registration)
    odometry.between(before, after, PlanarMotion(0.0, 0.05, 20.0))  # far from the truth
    assert len(calls) == fits and set(calls) == {iterations}
    with pytest.raises(ValueError, match="registration must be one of full, quick, coarse"):
        FloorOdometry(PAPER_GEOMETRY, "thorough")


def test_a_floor_without_texture_is_not_trusted() -> None:
    odometry = FloorOdometry(PAPER_GEOMETRY)
    grey = np.full((480, 640, 3), 120, dtype=np.uint8)
    noise = np.random.default_rng(0).normal(0.0, 1.5, grey.shape)
    flat = np.clip(grey + noise, 0, 255).astype(np.uint8)
    found = odometry.between(grey, flat, NOMINAL[0])
    assert not found.reliable
    assert found.texture < 4.0


def test_frames_of_another_size_are_refused_in_one_line() -> None:
    odometry = FloorOdometry(PAPER_GEOMETRY)
    with pytest.raises(ValueError, match="640 x 480"):
        odometry.view(np.zeros((240, 320, 3), dtype=np.uint8))


@pytest.mark.parametrize("preset", ["wide", "paper_fast"])
def test_other_cameras_get_a_view_of_their_own_floor(preset: str) -> None:
    # The fisheye and the half-size camera: the view follows the camera of the map's geometry.
    geometry = MapGeometry.from_preset(load_preset(preset))
    odometry = FloorOdometry(geometry)
    camera = geometry.camera()
    frame = np.zeros((camera.frame_height_px, camera.frame_width_px, 3), dtype=np.uint8)
    assert odometry.view(frame).fine.shape == odometry._seen.shape


def test_planar_motion_moves_points_into_the_frame_after_it() -> None:
    # A point 1 m ahead, after a 0.1 m step and a quarter turn left, lies 0.9 m to the right.
    moved = PlanarMotion(0.1, 0.0, 90.0).move_points(np.array([[1.0, 0.0]]))
    np.testing.assert_allclose(moved, [[0.0, -0.9]], atol=1e-12)
    matrix = PlanarMotion(0.1, 0.0, 90.0).matrix()
    np.testing.assert_allclose(matrix @ [0.0, -0.9, 1.0], [1.0, 0.0, 1.0], atol=1e-12)


def _path_error(memory: FreshFeltMemory, poses: list[np.ndarray]) -> float:
    """Mean distance [m] between the places the map says the rover has been and where it was
    (the true poses before the current one, in the rover's frame now)."""
    x, y, theta = poses[-1]
    cos, sin = math.cos(theta), math.sin(theta)
    past = np.array([p[:2] for p in poses[-1 - len(memory._path) : -1]]) - [x, y]
    truth = np.column_stack(
        [cos * past[:, 0] + sin * past[:, 1], -sin * past[:, 0] + cos * past[:, 1]]
    )
    return float(np.hypot(*(memory._path - truth).T).mean())


@cache
def _slipping_drive() -> tuple[list[np.ndarray], list[int], list[np.ndarray]]:
    """Frames, commands and true poses of 30 commands of the centreline driver on the training
    track in the paper world with slip noise 0.10 (a frame and pose before each command and
    after the last)."""
    from lfd_track.world.driver import CentrelineDriver

    env = gym.make("LfDTrack-v0", track="training", preset=_preset_path(SLIP)).unwrapped
    frame, info = env.reset(seed=5)
    driver = CentrelineDriver(env.track)
    frames, commands, poses = [frame], [], [np.array(info["pose"])]
    for _ in range(30):
        command = int(driver.act(poses[-1], info["progress_m"]))
        frame, _, terminated, truncated, info = env.step(command)
        assert not (terminated or truncated)
        frames.append(frame)
        commands.append(command)
        poses.append(np.array(info["pose"]))
    env.close()
    return frames, commands, poses


def test_a_visual_map_follows_a_slipping_rover_better_than_the_nominal_one() -> None:
    # The same drive through two maps, nominal and visual: the places the visual map says the
    # rover has been (up to 2.4 m back) lie within 6 cm of the true ones on average (4.4 cm when
    # written), the nominal map's at least twice as far (14 cm).
    frames, commands, poses = _slipping_drive()
    geometry = MapGeometry.from_preset(load_preset(_preset_path(SLIP)))
    values = np.zeros(40)
    errors = {}
    for motion in ("nominal", "visual"):
        memory = FreshFeltMemory(FreshFeltConfig(motion=motion), geometry)
        for index, command in enumerate(commands):
            memory.arrive(frames[index])
            memory.see(values)
            memory.note(command)
        memory.arrive(frames[-1])
        memory.see(values)
        errors[motion] = _path_error(memory, poses)
        if motion == "visual":
            assert memory.visual_moves >= 27
            assert memory.visual_moves + memory.nominal_moves == 30
    assert errors["visual"] < 0.06, errors
    assert errors["nominal"] > 2.0 * errors["visual"], errors


def test_a_nominal_map_ignores_frames_and_moves_as_before() -> None:
    # motion = "nominal" (the default): arrive() does nothing, so the map moves by the geometry's
    # motion exactly as note() alone did (the same bits).
    frames, commands, _ = _slipping_drive()
    rng = np.random.default_rng(1)
    values = [rng.uniform(0.0, 1.0, 40) for _ in frames]
    assert FreshFeltConfig().motion == "nominal"
    plain, framed = FreshFeltMemory(FreshFeltConfig()), FreshFeltMemory(FreshFeltConfig())
    for index, command in enumerate(commands):
        plain.see(values[index])
        framed.arrive(frames[index])
        framed.see(values[index])
        assert np.array_equal(plain.inputs(), framed.inputs())
        plain.note(command)
        framed.note(command)
    assert np.array_equal(plain._points, framed._points)
    assert np.array_equal(plain._path, framed._path)


def test_a_visual_map_without_frames_moves_by_the_nominal_motion() -> None:
    # Road values seen without their frames (a replay, a view from another pose): each command
    # moves the visual map by the nominal motion, the same bits as a nominal map.
    rng = np.random.default_rng(2)
    nominal = FreshFeltMemory(FreshFeltConfig())
    visual = FreshFeltMemory(FreshFeltConfig(motion="visual"))
    for command in (0, 0, 1, 0, 2, 2, 0):
        values = rng.uniform(0.0, 1.0, 40)
        nominal.see(values)
        visual.see(values)
        assert np.array_equal(nominal.inputs(), visual.inputs())
        nominal.note(command)
        visual.note(command)
    visual.place_before(0)
    nominal.place_before(0)
    assert np.array_equal(nominal._path, visual._path)
    assert visual.nominal_moves == 7 and visual.visual_moves == 0


def test_a_visual_map_forgets_the_last_view_when_a_frame_is_skipped() -> None:
    # Road values seen without the frame after a command: the command moves the map by its nominal
    # motion, and the next frame is not registered against the one before the skipped frame (that
    # motion would span two commands, measured against one command's guess).
    frames, commands, _ = _slipping_drive()
    geometry = MapGeometry.from_preset(load_preset(_preset_path(SLIP)))
    memory = FreshFeltMemory(FreshFeltConfig(motion="visual"), geometry)
    values = np.zeros(40)
    memory.arrive(frames[0])
    memory.see(values)
    memory.note(commands[0])
    memory.see(values)  # the frame after commands[0] never arrived
    assert memory._view is None and memory.nominal_moves == 1
    memory.note(commands[1])
    memory.arrive(frames[2])
    memory.see(values)
    assert memory.nominal_moves == 2 and memory.visual_moves == 0
    assert memory._view is not None


def test_a_visual_map_given_frames_of_another_size_moves_by_the_nominal_motion() -> None:
    # A controller drives on frames of another size than its map's camera (a note, not an
    # error, for its road values): nothing is measured from them, the map moves as a nominal one.
    rng = np.random.default_rng(3)
    nominal = FreshFeltMemory(FreshFeltConfig(), PAPER_GEOMETRY)
    visual = FreshFeltMemory(FreshFeltConfig(motion="visual"), PAPER_GEOMETRY)
    for command in (0, 1, 0, 2):
        values = rng.uniform(0.0, 1.0, 40)
        visual.arrive(rng.integers(0, 256, (240, 320, 3), dtype=np.uint8))
        nominal.see(values)
        visual.see(values)
        assert np.array_equal(nominal.inputs(), visual.inputs())
        nominal.note(command)
        visual.note(command)
    visual.arrive(np.zeros((240, 320, 3), dtype=np.uint8))
    assert np.array_equal(nominal._path, visual._path)
    assert visual.nominal_moves == 4 and visual.visual_moves == 0


def test_the_perception_hands_each_frame_to_a_visual_map() -> None:
    # Through the perception as the loops use it: a visual map's commands are moved by the
    # camera's measurement.
    from lfd_test_support import library_with_road

    from lfd_track.teaching.perception import Perception

    frames, commands, _ = _slipping_drive()
    geometry = MapGeometry.from_preset(load_preset(_preset_path(SLIP)))
    library, _ = library_with_road()
    perception = Perception(library, "frozen", FreshFeltConfig(motion="visual"), geometry=geometry)
    perception.start_episode()
    for index, command in enumerate(commands[:8]):
        perception.perceive(frames[index])
        perception.note(command)
    perception.perceive(frames[8])
    assert perception._memory.visual_moves >= 7
