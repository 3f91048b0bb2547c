"""Calibration on the robot (``lfd_track.hardware.calibrate``), its profile file
(``lfd_track.hardware.profile``) and ``--profile`` on the hardware commands.

The simulated robot's truth is what ``MapGeometry.from_preset`` defines (forward speed x control
period, pivot rate x control period); the calibration reads nothing but the frames. A synthetic
robot on a textured floor that moves exactly as told checks the matching alone, fast.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import cv2
import gymnasium as gym
import numpy as np
import pytest

import lfd_track  # noqa: F401  (registers the envs)
from lfd_track.cli import main
from lfd_track.core.camera_model import CameraConfig, CameraModel
from lfd_track.envs.presets import load_preset
from lfd_track.errors import CalibrationFailed, FileFormatError, LfdTrackError
from lfd_track.hardware.calibrate import FloorView, calibrate, floor_motion, strip_start
from lfd_track.hardware.profile import Calibration, RobotProfile, load_profile
from lfd_track.policy.map_geometry import MapGeometry, hardware_geometry

PAPER_PRESET = Path(__file__).resolve().parents[2] / "envs" / "paper.toml"
TOLERANCE = 0.05  # the acceptance: within 5 % of the preset's step and pivot


def _preset_file(tmp_path: Path, name: str, replacements: dict[str, str]) -> Path:
    """A copy of the paper preset with whole lines replaced (``key = ...`` -> the new line)."""
    lines = PAPER_PRESET.read_text().splitlines()
    out = []
    for line in lines:
        key = line.split("=")[0].strip()
        out.append(replacements.get(key, line))
    path = tmp_path / f"{name}.toml"
    path.write_text("\n".join(out).replace('name = "paper"', f'name = "{name}"') + "\n")
    return path


@pytest.fixture
def other_robot(tmp_path: Path) -> Path:
    """The paper world with a rover that pivots 15 % faster and drives 10 % slower."""
    return _preset_file(
        tmp_path,
        "other_robot",
        {
            "forward_speed_mps": "forward_speed_mps = 0.225",
            "pivot_rate_radps": "pivot_rate_radps = 1.15",
        },
    )


@pytest.fixture
def uniform_floor(tmp_path: Path) -> Path:
    """The paper world on a featureless floor: felt the carpet's colour, no texture, no light
    pools, no shadow."""
    path = _preset_file(
        tmp_path,
        "uniform",
        {
            "felt_rgb": "felt_rgb = [78, 54, 38]",
            "pool_count": "pool_count = 0",
            "shadow_darkness": "shadow_darkness = 0.0",
        },
    )
    flat = (
        "carpet_pile_strength = 0.0\ncarpet_fleck_strength = 0.0\ncarpet_patchiness = 0.0\n"
        "felt_fibre_strength = 0.0\nfelt_nonuniformity = 0.0\nfelt_tint_variation = 0.0\n"
    )
    path.write_text(path.read_text().replace("[appearance]\n", "[appearance]\n" + flat))
    return path


def _within(measured: float, truth: float) -> bool:
    return abs(measured / truth - 1.0) <= TOLERANCE


# ------------------------------------------------------------------ the simulated robot
def test_recovers_the_paper_presets_step_and_pivot():
    preset = load_preset("paper")
    env = gym.make("LfDTrack-v0", track="training", preset=preset)
    result = calibrate(
        env, preset.camera, reset_options={"pose": strip_start(env.unwrapped.track)}, seed=0
    )
    truth = MapGeometry.from_preset(preset)
    assert _within(result.step_m, truth.step_m), (result.step_m, truth.step_m)
    assert _within(result.pivot_deg, truth.pivot_deg), (result.pivot_deg, truth.pivot_deg)
    assert len(result.forward_step_m) == 3 and len(result.pivot_samples_deg) == 6
    assert result.step_spread < 0.10 and result.pivot_spread < 0.10


def test_cli_calibrates_another_robot_and_writes_its_profile(other_robot, tmp_path, capsys):
    out = tmp_path / "robot.json"
    code = main(["hardware", "calibrate", "--sim", "--preset", str(other_robot), "--out", str(out)])
    printed = capsys.readouterr().out
    assert code == 0
    assert "forward step" in printed and "pivot" in printed and "spread" in printed
    truth = MapGeometry.from_preset(load_preset(other_robot))
    paper = MapGeometry.from_preset(load_preset("paper"))
    assert truth.differences(paper)  # the robot is not the paper's: 10 % and 15 % off
    profile = load_profile(out)
    measured = profile.geometry
    assert _within(measured.step_m, truth.step_m), (measured.step_m, truth.step_m)
    assert _within(measured.pivot_deg, truth.pivot_deg), (measured.pivot_deg, truth.pivot_deg)
    assert measured.differences(truth) == []  # the camera is the preset's, the motion measured
    assert f"{measured.step_m:.4f} m" in printed and f"{measured.pivot_deg:.2f} deg" in printed
    assert profile.control_period_s == 0.4


def test_cli_on_a_uniform_floor_fails_in_one_line_and_keeps_the_old_profile(
    uniform_floor, tmp_path, capsys
):
    out = tmp_path / "robot.json"
    out.write_text("the old profile\n")
    code = main(
        ["hardware", "calibrate", "--sim", "--preset", str(uniform_floor), "--runs", "1"]
        + ["--out", str(out)]
    )
    err = capsys.readouterr().err
    assert code == 1
    assert err.count("\n") == 1 and "too uniform" in err, err
    assert out.read_text() == "the old profile\n"
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []


def test_cli_refuses_a_randomized_preset_and_mixed_flags(tmp_path, capsys):
    out = tmp_path / "robot.json"
    cases = (
        ["--sim", "--preset", "randomized"],
        ["--sim", "--camera", "http://phone/video"],
        ["--camera", "http://phone/video"],
        ["--camera", "c", "--serial", "s", "--preset", "paper"],
    )
    for flags in cases:
        assert main(["hardware", "calibrate", *flags, "--out", str(out)]) == 1, flags
        assert capsys.readouterr().err.count("\n") == 1
    assert not out.exists()


# ------------------------------------------------------------------ a synthetic robot
class FloorRobot:
    """A robot on a textured floor that moves exactly ``step_m`` per forward command and
    ``pivot_deg`` per pivot (``pivots``: a list of per-run pivots to cycle through instead), its
    frames drawn through the pinhole camera's floor homography. ``moves=False``: it stands."""

    def __init__(
        self,
        camera: CameraConfig,
        step_m: float = 0.08,
        pivot_deg: float = 27.0,
        *,
        pivots: list[float] | None = None,
        moves: bool = True,
        fail_after: int | None = None,
    ) -> None:
        rng = np.random.default_rng(7)
        # Texture at several scales, as carpet has (pile, flecks, patches): 8 mm to 0.2 m.
        noise = sum(
            cv2.GaussianBlur(rng.random((1500, 1500)).astype(np.float32), (0, 0), sigma)
            * sigma**0.5
            for sigma in (2.0, 8.0, 25.0)
        )
        noise = (noise - noise.min()) / (noise.max() - noise.min())
        self.texture = np.repeat((40 + 180 * noise).astype(np.uint8)[..., None], 3, axis=2)
        size = 0.004  # [m] per texel: a 6 m square around the start
        self.world_from_texture = np.array([[size, 0, -3.0], [0, size, -3.0], [0, 0, 1.0]])
        self.model = CameraModel(camera)
        self.step_m, self.pivot_deg, self.pivots = step_m, pivot_deg, pivots
        self.moves, self.fail_after = moves, fail_after
        self.pose = np.zeros(3)
        self.resets = self.steps = 0

    def _frame(self) -> np.ndarray:
        homography = self.model.image_from_world(self.pose) @ self.world_from_texture
        c = self.model.config
        size = (c.frame_width_px, c.frame_height_px)
        return cv2.warpPerspective(self.texture, homography, size, flags=cv2.INTER_LINEAR)

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        self.pose = np.zeros(3)
        self.resets += 1
        return self._frame(), {}

    def step(self, action: int):
        self.steps += 1
        if self.fail_after is not None and self.steps > self.fail_after:
            return self._frame(), 0.0, True, False, {"error": "/dev/rfcomm0: link lost"}
        pivot = self.pivot_deg
        if self.pivots is not None:
            pivot = self.pivots[(self.resets - 1) % len(self.pivots)]
        if self.moves and action == 0:
            self.pose[:2] += self.step_m * np.array(
                [math.cos(self.pose[2]), math.sin(self.pose[2])]
            )
        elif self.moves:
            self.pose[2] += math.radians(pivot if action == 1 else -pivot)
        return self._frame(), 0.0, False, False, {}


def test_floor_motion_finds_a_known_motion_about_the_pivot_centre():
    camera = CameraConfig(forward_offset_m=0.05)  # the camera ahead of the pivot centre
    robot = FloorRobot(camera)
    view = FloorView(camera)
    before, _ = robot.reset()
    robot.pose = np.array([0.06, 0.01, math.radians(4.0)])
    motion = floor_motion(view, before, robot._frame())
    assert motion.matched
    assert motion.forward_m == pytest.approx(0.06, abs=0.002)
    assert motion.left_m == pytest.approx(0.01, abs=0.002)
    assert motion.turn_deg == pytest.approx(4.0, abs=0.1)
    robot.pose = np.array([0.0, 0.0, math.radians(-26.0)])
    pivot = floor_motion(view, before, robot._frame(), turn_only=True)
    assert pivot.matched and pivot.turn_deg == pytest.approx(-26.0, abs=0.2)
    assert pivot.forward_m == 0.0 and pivot.left_m == 0.0


def test_calibrate_measures_the_synthetic_robot_and_the_same_frames_give_the_same_numbers():
    camera = CameraConfig()
    first = calibrate(FloorRobot(camera), camera, runs=2, commands_per_run=2)
    assert first.step_m == pytest.approx(0.08, rel=0.01)
    assert first.pivot_deg == pytest.approx(27.0, rel=0.01)
    assert calibrate(FloorRobot(camera), camera, runs=2, commands_per_run=2) == first


def test_a_robot_that_does_not_move_fails():
    camera = CameraConfig()
    with pytest.raises(CalibrationFailed, match="did not move"):
        calibrate(FloorRobot(camera, moves=False), camera, runs=1, commands_per_run=1)


def test_scattered_estimates_fail():
    camera = CameraConfig()
    robot = FloorRobot(camera, pivots=[15.0, 30.0])  # every other run pivots twice as far
    with pytest.raises(CalibrationFailed, match="too scattered"):
        calibrate(robot, camera, runs=2, commands_per_run=1)


def test_a_robot_that_stops_fails_naming_why():
    camera = CameraConfig()
    with pytest.raises(CalibrationFailed, match="link lost"):
        calibrate(FloorRobot(camera, fail_after=2), camera, runs=1, commands_per_run=2)


def test_calibration_failed_is_a_user_error():
    assert issubclass(CalibrationFailed, LfdTrackError)


# ------------------------------------------------------------------ the profile file
def _profile(step_m: float = 0.09, pivot_deg: float = 26.0) -> RobotProfile:
    calibration = Calibration(
        commands_per_run=3,
        forward_step_m=(step_m, step_m * 1.01, step_m * 0.99),
        left_pivot_deg=(pivot_deg, pivot_deg * 1.02),
        right_pivot_deg=(pivot_deg * 0.98, pivot_deg),
    )
    geometry = MapGeometry.from_camera(
        CameraConfig(), step_m=calibration.step_m, pivot_deg=calibration.pivot_deg
    )
    return RobotProfile(geometry, calibration, control_period_s=0.4)


def test_profile_round_trips_and_writes_the_same_bytes(tmp_path):
    profile = _profile()
    path = tmp_path / "robot.json"
    profile.save(path)
    assert load_profile(path) == profile
    first = path.read_bytes()
    load_profile(path).save(path)
    assert path.read_bytes() == first


@pytest.mark.parametrize(
    ("edit", "problem"),
    [
        (lambda d: "{not json", "not valid JSON"),
        (lambda d: {**d, "format": "lfd-track controller"}, "not a robot profile"),
        (lambda d: {**d, "schema_version": 2}, "schema_version 2"),
        (lambda d: {**d, "extra": 1}, "unknown key 'extra'"),
        (lambda d: {k: v for k, v in d.items() if k != "calibration"}, "missing 'calibration'"),
        (lambda d: {**d, "control_period_s": 0}, "control_period_s"),
        (lambda d: {**d, "map_geometry": {**d["map_geometry"], "step_m": -0.1}}, "step_m"),
        (
            lambda d: {**d, "calibration": {**d["calibration"], "left_pivot_deg": []}},
            "left_pivot_deg",
        ),
    ],
)
def test_a_bad_profile_is_one_line_naming_the_file(tmp_path, edit, problem):
    import json

    path = tmp_path / "bad.json"
    edited = edit(_profile().to_dict())
    path.write_text(edited if isinstance(edited, str) else json.dumps(edited))
    with pytest.raises(FileFormatError) as info:
        load_profile(path)
    message = str(info.value)
    assert message.startswith(str(path)) and problem in message and "\n" not in message


def test_a_bad_profile_stops_hardware_demo_before_the_robot(tmp_path, capsys):
    bad = tmp_path / "bad.json"
    bad.write_text("{}")
    code = main(
        ["hardware", "demo", "--camera", "http://phone/video", "--serial", "socket://x:1"]
        + ["--out", str(tmp_path / "d.lfdemo"), "--profile", str(bad)]
    )
    err = capsys.readouterr().err
    assert code == 1 and str(bad) in err and err.count("\n") == 1


# ------------------------------------------------------------------ --profile on the commands
class _Stop(Exception):
    pass


def test_profile_is_the_map_geometry_hardware_drive_uses(tmp_path, monkeypatch):
    from lfd_track.cli import build_parser
    from lfd_track.cli import hardware as cli_hardware
    from lfd_track.policy import controller as controller_module

    profile_path = tmp_path / "robot.json"
    _profile().save(profile_path)
    seen: list[MapGeometry] = []

    class FakeController:
        def perception(self, rule: str | None = None, *, world_geometry: MapGeometry) -> None:
            seen.append(world_geometry)
            raise _Stop

    class FakeEnv:
        def close(self) -> None:
            pass

    monkeypatch.setattr(
        controller_module.Controller, "load", classmethod(lambda cls, p: FakeController())
    )
    monkeypatch.setattr(cli_hardware, "_make_env", lambda args, **kw: FakeEnv())
    base = ["hardware", "drive", "c.json", "--camera", "c", "--serial", "s"]
    for extra in (["--profile", str(profile_path)], []):
        args = build_parser().parse_args(base + extra)
        with pytest.raises(_Stop):
            cli_hardware._cmd_drive(args)
    assert seen[0] == _profile().geometry
    assert seen[1] == hardware_geometry(period_s=0.4)  # unchanged without --profile


def test_a_profile_measured_at_another_period_says_so(tmp_path, capsys):
    from lfd_track.cli import build_parser
    from lfd_track.cli.hardware import _profile_geometry

    path = tmp_path / "robot.json"
    _profile().save(path)
    base = ["hardware", "drive", "c.json", "--camera", "c", "--serial", "s", "--profile", str(path)]
    assert _profile_geometry(build_parser().parse_args(base)) == _profile().geometry
    assert capsys.readouterr().err == ""
    _profile_geometry(build_parser().parse_args(base + ["--period", "0.3"]))
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "0.4 s" in err and "0.3 s" in err and str(path) in err


def test_profile_is_the_map_geometry_hardware_demo_records(tmp_path, monkeypatch):
    import contextlib

    from lfd_track.cli import build_parser
    from lfd_track.cli import hardware as cli_hardware
    from lfd_track.hardware import teleop

    profile_path = tmp_path / "robot.json"
    _profile().save(profile_path)
    seen: list[dict[str, Any]] = []

    class FakeEnv:
        last_error = None

        def reset(self):
            return np.zeros((480, 640, 3), np.uint8), {}

        def close(self) -> None:
            pass

    def recorder(path: Any, **kwargs: Any) -> None:
        seen.append(kwargs)
        raise _Stop

    monkeypatch.setattr(cli_hardware, "_make_env", lambda args, **kw: FakeEnv())
    monkeypatch.setattr(teleop, "TerminalKeys", contextlib.nullcontext)
    monkeypatch.setattr(teleop, "DemonstrationRecorder", recorder)
    base = ["hardware", "demo", "--camera", "c", "--serial", "s"]
    for extra in (["--profile", str(profile_path)], []):
        args = build_parser().parse_args(base + ["--out", str(tmp_path / "d.lfdemo")] + extra)
        with pytest.raises(_Stop):
            cli_hardware._cmd_demo(args)
    assert seen[0]["map_geometry"] == _profile().geometry
    assert seen[0]["metadata"]["map_geometry"] == _profile().geometry.to_dict()
    assert seen[1]["map_geometry"] == hardware_geometry(period_s=0.4)
    assert "map_geometry" not in seen[1]["metadata"]  # a recording without a profile unchanged


def test_teach_takes_the_profile_on_hardware_only(tmp_path):
    from lfd_track.cli import build_parser
    from lfd_track.cli.teach import run, teach_config

    profile_path = tmp_path / "robot.json"
    _profile().save(profile_path)
    base = ["teach", "--out", str(tmp_path / "t.lfdemo"), "--profile", str(profile_path)]
    args = build_parser().parse_args(
        base + ["--backend", "hardware", "--camera", "c", "--serial", "s"]
    )
    assert teach_config(args).profile == _profile().geometry
    plain = build_parser().parse_args(["teach", "--out", str(tmp_path / "t.lfdemo")])
    assert teach_config(plain).profile is None
    with pytest.raises(LfdTrackError, match="--profile is for --backend hardware"):
        run(build_parser().parse_args(base))


def test_hardware_session_uses_the_profile(monkeypatch, tmp_path):
    """The teaching station on hardware: its perception's map assumes the profile's geometry
    (the robot's env is replaced by a stand-in that refuses to open)."""
    from lfd_track.hardware import env as hardware_env
    from lfd_track.policy.memory_config import FreshFeltConfig
    from lfd_track.web.session import TeachConfig, open_session

    seen: list[Any] = []

    class FakeHardwareEnv:
        def __init__(self, **kwargs: Any) -> None:
            self.link = self.camera = None

        def close(self) -> None:
            pass

    def perception(*args: Any, geometry: Any = None, **kwargs: Any) -> Any:
        seen.append(geometry)
        raise _Stop

    monkeypatch.setattr(hardware_env, "HardwareEnv", FakeHardwareEnv)
    monkeypatch.setattr("lfd_track.web.session.Perception", perception)
    config = TeachConfig(
        out=tmp_path / "t.lfdemo",
        backend="hardware",
        camera="c",
        serial="s",
        memory=FreshFeltConfig(),
        profile=_profile().geometry,
    )
    with pytest.raises(_Stop):
        open_session(config)
    assert seen == [_profile().geometry]


def test_evolve_reads_the_geometry_a_recording_names():
    from lfd_track.cli.evolve import _recorded_map_geometry

    geometry = _profile().geometry
    meta = {"control_period_s": 0.4, "map_geometry": geometry.to_dict()}
    assert _recorded_map_geometry(meta) == geometry
    assert _recorded_map_geometry({"control_period_s": 0.4}) == hardware_geometry(period_s=0.4)
    with pytest.raises(LfdTrackError, match="map geometry"):
        _recorded_map_geometry({"map_geometry": {"step_m": 1}})


def test_calibrate_drives_the_real_robots_env_and_stops_it(tmp_path, capsys):
    """``hardware calibrate`` through ``HardwareEnv`` on loopback fakes (a board that acks every
    drive, a phone whose view never changes): every command is sent, the motors are stopped,
    and a robot whose view does not move fails in one line with nothing written."""
    from lfd_test_support import load_test_module

    here = Path(__file__).parent
    board_module = load_test_module(here / "test_link.py", "_lfd_hw_test_link")
    camera_module = load_test_module(here / "test_camera.py", "_lfd_hw_test_camera")
    still = np.ascontiguousarray(FloorRobot(CameraConfig()).reset()[0][:, :, ::-1])  # BGR
    out = tmp_path / "robot.json"
    with board_module.FakeBoard() as board, camera_module.MjpegServer(lambda i: still) as server:
        code = main(
            ["hardware", "calibrate", "--camera", server.url, "--serial", board.url]
            + ["--period", "0.1", "--boot-wait", "0.3", "--runs", "1", "--commands-per-run", "1"]
            + ["--out", str(out)]
        )
    err = capsys.readouterr().err
    assert code == 1 and "did not move" in err and err.count("\n") == 1, err
    assert not out.exists()
    drives = board.drives()
    assert {"F", "L", "R"} <= set(drives) and drives[-1] == "S"
