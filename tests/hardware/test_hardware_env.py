"""``LfDTrack-Hardware-v0`` on loopback: a fake board or the simulated firmware, an MJPEG server."""

from __future__ import annotations

import _thread
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import serial
from lfd_test_support import load_test_module

import lfd_track  # noqa: F401 - registers the environments
from lfd_track.hardware import wire
from lfd_track.hardware.env import HardwareEnv


def _sibling(name: str):
    """A sibling test module (it holds the loopback fakes), loaded by path."""
    return load_test_module(Path(__file__).with_name(f"{name}.py"), f"_lfd_hw_{name}")


FakeBoard = _sibling("test_link").FakeBoard
MjpegServer = _sibling("test_camera").MjpegServer

FAST = {"control_period_s": 0.1, "link_options": {"boot_wait_s": 0.3}}


def make_env(board, server, **kwargs) -> HardwareEnv:
    options = {**FAST, **kwargs}
    return HardwareEnv(camera_url=server.url, serial_url=board.url, **options)


def test_steps_send_the_commands_and_return_fresh_frames() -> None:
    with FakeBoard() as board, MjpegServer() as server:
        env = gym.make("LfDTrack-Hardware-v0", camera_url=server.url, serial_url=board.url, **FAST)
        try:
            obs, info = env.reset(seed=0)
            assert obs.shape == (480, 640, 3) and obs.dtype == np.uint8
            assert info["failure"] is None and board.watchdog_ms == 300
            actions = [0, 1, 2, 0]
            for action in actions:
                obs, reward, terminated, truncated, info = env.step(action)
                assert (reward, terminated, truncated, info["failure"]) == (0.0, False, False, None)
                assert env.observation_space.contains(obs)
            assert info["link"]["acks"] >= 6 and info["link"]["missed"] == 0
            assert info["link"]["rtt_ms"] > 0
            assert info["command"] == "F" and info["board_state"] == "F"
        finally:
            env.close()
    drives = board.drives()
    assert drives[0] == "S" and drives[-1] == "S"  # reset stops, close stops
    sent = [d for i, d in enumerate(drives) if i == 0 or d != drives[i - 1]]
    assert sent == ["S", "F", "L", "R", "F", "S"]


def test_between_steps_stop_mode_stops_after_each_period() -> None:
    with FakeBoard() as board, MjpegServer() as server:
        env = make_env(board, server, between_steps="stop")
        try:
            env.reset()
            env.step(1)
            assert board.state == "S"
            env.step(2)
        finally:
            env.close()
    collapsed = [d for i, d in enumerate(board.drives()) if i == 0 or d != board.drives()[i - 1]]
    assert collapsed == ["S", "L", "S", "R", "S"]


def test_step_needs_reset_and_a_valid_action() -> None:
    with FakeBoard() as board, MjpegServer() as server:
        env = make_env(board, server)
        try:
            with pytest.raises(RuntimeError, match="reset"):
                env.step(0)
            env.reset()
            with pytest.raises(ValueError, match="action"):
                env.step(3)
        finally:
            env.close()


@pytest.mark.parametrize("mode", ["silent", "corrupt", "disconnect"])
def test_link_faults_stop_and_end_the_episode(mode: str) -> None:
    with FakeBoard(mode=mode, fault_after=6) as board, MjpegServer() as server:
        env = make_env(board, server)
        try:
            env.reset()
            for _ in range(50):
                _, _, terminated, _, info = env.step(0)
                if terminated:
                    break
            assert terminated and info["failure"] == "link_lost"
            assert board.url in info["error"]
            with pytest.raises(RuntimeError, match="reset"):
                env.step(0)
        finally:
            env.close()
    if mode != "disconnect":
        # The board still hears the host: the last thing it was told is stop.
        assert board.drives()[-1] == "S"


def test_stalled_camera_stops_the_robot_within_1_5_s() -> None:
    with FakeBoard() as board, MjpegServer() as server:
        env = make_env(board, server, control_period_s=0.4)  # default period and timeout
        try:
            env.reset()
            env.step(0)
            server.stall()
            for _ in range(10):
                _, _, terminated, _, info = env.step(0)
                if terminated:
                    break
            stalled_at = server.last_sent_at
            assert terminated and info["failure"] == "camera_timeout"
            assert "no new frame" in info["error"]
            stop_times = [
                t
                for t, f in board.received
                if f.type == wire.DRIVE and f.args == ("S",) and t > stalled_at
            ]
            assert stop_times and stop_times[0] - stalled_at < 1.5
        finally:
            env.close()


def test_keyboard_interrupt_during_a_drive_sends_stop() -> None:
    drives_seen = []

    def interrupt_on_third_forward(board, frame) -> None:
        if frame.type == wire.DRIVE and frame.args == ("F",):
            drives_seen.append(frame)
            if len(drives_seen) == 3:
                _thread.interrupt_main()  # what Ctrl-C does to the control loop

    with FakeBoard(on_frame=interrupt_on_third_forward) as board, MjpegServer() as server:
        env = make_env(board, server, control_period_s=0.4)
        try:
            env.reset()
            with pytest.raises(KeyboardInterrupt):
                for _ in range(20):
                    env.step(0)
            assert board.wait_for(lambda b: b.drives()[-1:] == ["S"])
            assert board.state == "S"
            with pytest.raises(RuntimeError, match="reset"):
                env.step(0)
        finally:
            env.close()


def test_latched_estop_ends_the_episode_until_cleared() -> None:
    with FakeBoard() as board, MjpegServer() as server:
        env = make_env(board, server)
        try:
            env.reset()
            board.estopped = True  # someone pressed the e-stop
            _, _, terminated, _, info = env.step(0)
            assert terminated and info["failure"] == "estopped"
            env.reset(options={"clear_estop": True})
            _, _, terminated, _, info = env.step(0)
            assert not terminated and info["board_state"] == "F"
        finally:
            env.close()


def _motor_states(samples) -> list[str]:
    """Collapse the firmware's motor log to F/L/R/S runs (pin-by-pin glitches dropped)."""
    states = []
    for sample, following in zip(samples, [*samples[1:], None], strict=True):
        if following is not None and following.t_s - sample.t_s < 0.001:
            continue  # an intermediate state while the firmware sets one pin after another
        if sample.left_pwm == 0 and sample.right_pwm == 0:
            state = "S"
        else:
            state = {(0, 0): "F", (1, 0): "L", (0, 1): "R"}.get(
                (sample.left_dir, sample.right_dir), "?"
            )
        if not states or states[-1] != state:
            states.append(state)
    return states


def _runs(letters: list[str]) -> list[str]:
    return [x for i, x in enumerate(letters) if i == 0 or x != letters[i - 1]]


@pytest.fixture(scope="module")
def controller_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A controller evolved from a short simulated demonstration, saved to a file.

    Only 30 generations (a few seconds in all): enough for a real evolved network with a road
    library learned from rendered frames; how well it drives is not what these tests check.
    """
    from lfd_track.dataset import load_demonstration
    from lfd_track.demo.demonstrator import run_demonstration
    from lfd_track.learning.ga import GAConfig, evolve
    from lfd_track.policy.controller import Controller
    from lfd_track.vision.road_library import RoadLibrary

    folder = tmp_path_factory.mktemp("controller")
    demo_path = folder / "demo.lfdemo"
    run_demonstration(demo_path, seed=1, fsync=False)
    demo = load_demonstration(demo_path)
    result = evolve(
        demo.road_values, demo.commands, GAConfig(generations=30), np.random.default_rng(0)
    )
    library = RoadLibrary.from_dict(demo.metadata["road_library"])
    path = folder / "controller.json"
    Controller.from_evolution(library, result, seed=0).save(path)
    return path


@pytest.mark.simavr
def test_end_to_end_on_the_simulated_firmware(simulated_board, controller_file: Path) -> None:
    """Rendered frames -> MJPEG -> saved controller -> serial -> firmware -> motor log."""
    from lfd_track.envs.track_env import LfDTrackEnv
    from lfd_track.policy.controller import Controller

    controller = Controller.load(controller_file)
    sim = LfDTrackEnv(track="training")
    first, _ = sim.reset(seed=3)

    def frame(index: int) -> np.ndarray:
        # The server thread reads the latest rendered frame (replaced, never written in place).
        return np.ascontiguousarray(sim.camera_frame[..., ::-1])  # the server encodes BGR

    with MjpegServer(make_frame=frame, period_s=0.05) as server:
        env = gym.make(
            "LfDTrack-Hardware-v0",
            camera_url=server.url,
            serial_url=simulated_board.serial_url,
            control_period_s=0.2,
        )
        sent = []
        try:
            obs, _ = env.reset(seed=0)
            # Nothing has moved yet, so the camera delivered the rendered start frame (JPEG'd).
            assert np.abs(obs.astype(np.int16) - first).mean() < 8.0  # about 3 from JPEG
            controller.reset()
            log_start = len(simulated_board.motor_log())
            for _ in range(24):
                action = controller.act(obs)
                sim.step(action)  # the simulated rover moves while the real one would
                obs, _, terminated, _, info = env.step(action)
                assert not terminated, info
                sent.append("FLR"[action])
            # A late ack under load is retried; what matters is that the link never failed.
            assert info["link"]["acks"] >= 24 and info["link"]["consecutive_failures"] == 0
        finally:
            env.close()
            sim.close()
    states = _motor_states(simulated_board.motor_log()[max(log_start - 1, 0) :])
    assert states[0] == "S" and states[-1] == "S"
    # Every command reached the motors, in order. A starved host (a loaded machine) may let the
    # 300 ms lease lapse between two commands: the board then stops, as it must, and the next
    # drive frame starts the motors again, so brief stops in between are allowed.
    assert _runs([x for x in states if x != "S"]) == _runs(sent)
    assert len(set(sent)) >= 2  # the log check covers more than one kind of command


# ------------------------------------------------------------------------------------ CLI
def _run_cli(*argv: str) -> int:
    from lfd_track.cli.hardware import main

    return main(["hardware", *argv])


def test_cli_check_runs_the_motionless_self_test(capsys) -> None:
    with FakeBoard() as board:
        code = _run_cli("check", "--serial", board.url, "--pings", "5", "--boot-wait", "0.3")
    out = capsys.readouterr().out
    assert code == 0, out
    assert "firmware version: fake-1" in out and "round trip over 5" in out and "OK:" in out
    assert board.state == "S" and not board.estopped  # e-stop cleared, motors off


def test_cli_check_explains_an_unknown_firmware_version(capsys) -> None:
    with FakeBoard(boot=False) as board:  # booted before the port opened
        code = _run_cli("check", "--serial", board.url, "--pings", "1")
    out = capsys.readouterr().out
    assert code == 0, out
    assert "firmware version: unknown (the board does not answer the version query," in out
    assert "--boot-wait S" in out


def test_cli_check_asks_for_the_version_without_a_reset(capsys) -> None:
    with FakeBoard(boot=False, version="fake-1.1") as board:  # booted before the port opened
        code = _run_cli("check", "--serial", board.url, "--pings", "1")
    out = capsys.readouterr().out
    assert code == 0, out
    assert "firmware version: fake-1.1 (last reset: reset pin)" in out


def test_cli_check_boot_wait_sees_a_board_reset_during_the_wait(capsys) -> None:
    with FakeBoard(boot_delay_s=0.3) as board:  # someone presses reset after the port opened
        code = _run_cli("check", "--serial", board.url, "--pings", "1", "--boot-wait", "5")
    out = capsys.readouterr().out
    assert code == 0, out
    assert "waiting up to 5 s for the board's boot frame" in out
    assert "firmware version: fake-1" in out


def test_cli_drive_runs_a_controller_file(controller_file: Path, capsys) -> None:
    with FakeBoard() as board, MjpegServer() as server:
        code = _run_cli(
            "drive", str(controller_file), "--camera", server.url, "--serial", board.url,
            "--steps", "3", "--period", "0.1", "--boot-wait", "0.3",
        )  # fmt: skip
    out = capsys.readouterr().out
    assert code == 0, out
    assert out.count("step ") == 3 and board.drives()[-1] == "S"
    # Each step says how long its decision took, and the drive ends with their spread against
    # the budget.
    assert len(re.findall(r"^step \d: .*, decision [0-9.]+ ms\)$", out, re.MULTILINE)) == 3
    assert "frame to command over 3 steps: median " in out and "the decision budget is 5 ms" in out


def test_cli_user_errors_are_one_line(tmp_path: Path, capsys) -> None:
    code = _run_cli(
        "drive", str(tmp_path / "missing.json"), "--camera", "x.avi", "--serial", "loop://",
    )  # fmt: skip
    err = capsys.readouterr().err
    assert code == 1
    assert err.count("\n") == 1 and "missing.json" in err and "Traceback" not in err
    code = _run_cli("check", "--serial", "socket://127.0.0.1:1")
    err = capsys.readouterr().err
    assert code == 1 and err.count("\n") == 1 and "cannot open serial link" in err


def test_cli_demo_without_a_terminal_creates_no_recording(
    tmp_path: Path, capsys, monkeypatch
) -> None:
    out = tmp_path / "new.lfdemo"
    null = open(os.devnull)  # noqa: SIM115 (closed below) -- stdin as in `... < /dev/null`
    monkeypatch.setattr(sys, "stdin", null)
    with null, FakeBoard() as board, MjpegServer() as server:
        code = _run_cli(
            "demo", "--out", str(out), "--camera", server.url, "--serial", board.url,
            "--period", "0.1", "--boot-wait", "0.3",
        )  # fmt: skip
    err = capsys.readouterr().err
    assert code == 1 and "interactive terminal" in err and err.count("\n") == 1
    assert not out.exists()  # no stub left to block the next run with "file exists"
    assert board.drives()[-1:] in ([], ["S"])


def test_teleop_records_a_demonstration(tmp_path: Path) -> None:
    from lfd_track.core.commands import Command
    from lfd_track.dataset import load_demonstration
    from lfd_track.hardware.teleop import DemonstrationRecorder, run_teleop

    class ScriptedKeys:
        def __init__(self, keys):
            self.keys = list(keys)

        def poll(self, timeout_s):
            return self.keys.pop(0) if self.keys else "q"

    keys = ScriptedKeys(["w", "\x1b[D", "d", " ", "p", "w", "x", "q", "w"])
    out = tmp_path / "demo.lfdemo"
    with FakeBoard() as board, MjpegServer() as server:
        env = make_env(board, server, between_steps="stop")
        try:
            obs, _ = env.reset()
            with DemonstrationRecorder(out, library_only=1) as recorder:
                sent = run_teleop(env, obs, keys, recorder, say=lambda _: None)
                assert recorder.learning is False  # "p" paused library learning
        finally:
            env.close()
    assert sent == 4
    demo = load_demonstration(out)
    assert demo.metadata["complete"]
    assert demo.commands.tolist() == [Command.LEFT, Command.RIGHT, Command.FORWARD]
    assert demo.learned.tolist() == [True, True, False]
    assert demo.road_values.shape == (3, 40)
    assert _runs(board.drives()) == ["S", "F", "S", "L", "S", "R", "S", "F", "S"]


@pytest.mark.simavr
def test_cli_check_with_lease_test_on_the_simulated_firmware(simulated_board, capsys) -> None:
    simulated_board.reset(cause="power-on")
    code = _run_cli("check", "--serial", simulated_board.serial_url, "--pings", "3", "--lease-test")
    out = capsys.readouterr().out
    assert code == 0, out
    # No boot wait and no reset: the version comes from the version query.
    assert "firmware version: 1.2 (last reset: power-on)" in out
    assert "lease watchdog stopped the motors" in out and "OK:" in out


def _ping_reply(url: str, seq: int) -> wire.Frame:
    """Ping the board at ``url`` until it answers (it may still be booting); return the reply."""
    port = serial.serial_for_url(url, baudrate=9600, timeout=0.05)
    try:
        parser = wire.FrameParser()
        deadline = time.monotonic() + 5.0  # failure guard
        while time.monotonic() < deadline:
            port.write(wire.encode_frame(wire.PING, seq))
            reply_deadline = time.monotonic() + 0.5
            while time.monotonic() < reply_deadline:
                for item in parser.feed(port.read(64)):
                    if isinstance(item, wire.Frame) and item.seq == seq:
                        return item
        raise AssertionError(f"the board at {url} answered no ping")
    finally:
        port.close()


@pytest.mark.simavr
def test_cli_check_leaves_a_latch_from_a_watchdog_reset_latched(simulated_board, capsys) -> None:
    simulated_board.reset(cause="power-on")
    _ping_reply(simulated_board.serial_url, 8)  # booted: its watchdog is armed
    simulated_board.hang()  # the watchdog resets the board, which boots latched
    try:
        code = _run_cli(
            "check", "--serial", simulated_board.serial_url, "--pings", "2", "--lease-test"
        )
        out = capsys.readouterr().out
        assert code == 0, out
        assert "firmware version: 1.2 (last reset: hardware watchdog)" in out
        assert "e-stop was latched when check connected" in out and "lease test skipped" in out
        assert _ping_reply(simulated_board.serial_url, 9).args == ("X", "1")
    finally:
        simulated_board.reset(cause="power-on")  # the next test gets an unlatched board


def _processes_mentioning(text: str) -> list[int]:
    """Ids of running processes whose command line contains ``text`` (Linux ``/proc``)."""
    found = []
    for cmdline in Path("/proc").glob("[0-9]*/cmdline"):
        try:
            if text.encode() in cmdline.read_bytes():
                found.append(int(cmdline.parent.name))
        except OSError:
            continue  # the process ended while we looked
    return found


@pytest.mark.simavr
@pytest.mark.parametrize("keep_log", [False, True])
def test_cli_sim_stops_cleanly_on_sigterm(simulated_board, keep_log: bool) -> None:
    """``kill PID`` stops the harness and removes its files, as Ctrl-C does."""
    argv = [sys.executable, "-m", "lfd_track.cli.hardware", "hardware", "sim"]
    proc = subprocess.Popen(
        argv + (["--keep-log"] if keep_log else []),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=Path(__file__).resolve().parents[2],
    )
    log_path = None
    try:
        lines = []
        while not lines or not lines[-1].startswith("press Ctrl-C"):
            line = proc.stdout.readline()  # returns "" at once if the command died
            assert line, f"hardware sim ended early: {lines} {proc.communicate()[1]}"
            lines.append(line)
        log_path = Path(
            next(x for x in lines if x.startswith("motor log:")).split(": ", 1)[1].strip()
        )
        assert log_path.parent.name.startswith("lfd-rover-sim-") and log_path.is_file()
        assert _processes_mentioning(str(log_path))  # the harness runs
        proc.send_signal(signal.SIGTERM)
        out, err = proc.communicate(timeout=30)
        assert proc.returncode == 0, err
        assert "stopping the simulated board" in out
        assert not _processes_mentioning(str(log_path))  # the harness was stopped
        if keep_log:
            assert log_path.is_file() and f"motor log kept: {log_path}" in out
        else:
            assert not log_path.parent.exists()
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
        if log_path is not None:
            # Whatever a failure left behind: the harness of this run, its folder.
            for pid in _processes_mentioning(str(log_path)):
                os.kill(pid, signal.SIGKILL)
            shutil.rmtree(log_path.parent, ignore_errors=True)


@pytest.mark.simavr
def test_cli_demo_records_memory_inputs_on_the_simulated_firmware(
    simulated_board, tmp_path: Path, capsys, monkeypatch
) -> None:
    """``hardware demo --memory last_bend`` records the memory inputs with every case, as
    ``demo`` and ``teach`` do, and says so in the file (so ``evolve`` trains a policy reading
    them)."""
    from lfd_track.core.commands import Command
    from lfd_track.dataset import load_demonstration
    from lfd_track.hardware import teleop
    from lfd_track.policy.memory import LastBendConfig

    class Keys:
        """Forward, left, right, forward, then quit."""

        def __init__(self, *args: object) -> None:
            self.keys = ["w", "a", "d", "w", "q"]

        def __enter__(self) -> Keys:
            return self

        def __exit__(self, *exc: object) -> None:
            pass

        def poll(self, timeout_s: float) -> str | None:
            return self.keys.pop(0) if self.keys else "q"

    monkeypatch.setattr(teleop, "TerminalKeys", Keys)
    simulated_board.reset(cause="power-on")
    out = tmp_path / "memory.lfdemo"
    with MjpegServer() as server:
        code = _run_cli(
            "demo", "--out", str(out), "--camera", server.url,
            "--serial", simulated_board.serial_url, "--period", "0.1",
            "--library-only", "0", "--memory", "last_bend",
        )  # fmt: skip
    assert code == 0, capsys.readouterr().err
    demo = load_demonstration(out)
    memory = LastBendConfig()
    assert demo.metadata["complete"]
    assert demo.commands.tolist() == [Command.FORWARD, Command.LEFT, Command.RIGHT, Command.FORWARD]
    assert demo.memory_settings() == memory
    assert demo.memory is not None and demo.memory.shape == (4, memory.n_inputs)
    assert demo.inputs.shape == (4, 40 + memory.n_inputs)
