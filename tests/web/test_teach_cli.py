"""``lfd-track teach`` as a user runs it: the printed URL, the token, Ctrl-C, a crash."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
import urllib.error
import urllib.request
from collections.abc import Callable
from pathlib import Path
from urllib.parse import urlsplit

import pytest
from websockets.sync.client import connect

from lfd_track.cli import main
from lfd_track.dataset import load_demonstration

REPO = Path(__file__).resolve().parents[2]
WAIT_S = 30.0  # failure guard only


def start_teach(*argv: str) -> tuple[subprocess.Popen, list[str]]:
    """Run ``lfd-track teach`` and read its output up to "press Ctrl-C"."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "lfd_track.cli", "teach", "--port", "0", "--period", "0.1", *argv],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=REPO,
    )
    lines: list[str] = []
    while not lines or not lines[-1].startswith("press Ctrl-C"):
        line = proc.stdout.readline()  # "" at once if the command died
        if not line:
            proc.kill()
            raise AssertionError(f"teach ended early: {lines} {proc.communicate()[1]}")
        lines.append(line)
    return proc, lines


def loopback(url: str) -> str:
    """The printed URL, reached over loopback (the test never leaves this machine)."""
    parts = urlsplit(url)
    return parts._replace(netloc=f"127.0.0.1:{parts.port}").geturl()


def http_status(url: str) -> int:
    opener = urllib.request.build_opener(urllib.request.ProxyHandler({}))
    try:
        with opener.open(url, timeout=10) as response:
            return response.status
    except urllib.error.HTTPError as exc:
        return exc.code


def drive(url: str, commands: list[str]) -> None:
    """Tap ``commands`` one by one over the WebSocket, each once the previous one is recorded."""
    parts = urlsplit(url)
    ws_url = parts._replace(scheme="ws", path="/ws").geturl()
    deadline = time.monotonic() + WAIT_S
    with connect(ws_url, proxy=None, max_queue=None) as ws:
        for given, command in enumerate(commands, start=1):
            ws.send(json.dumps({"type": "press", "command": command}))
            ws.send(json.dumps({"type": "release"}))
            while True:
                assert time.monotonic() < deadline, f"command {given} was not recorded"
                message = ws.recv(timeout=WAIT_S)
                if isinstance(message, str):
                    status = json.loads(message)
                    if status.get("cases") == given and not status["driving"]:
                        break


def teach_and_stop(
    argv: list[str],
    commands: list[str],
    stop_signal: int = signal.SIGINT,
    before: Callable[[str, list[str]], None] | None = None,
) -> tuple[str, str, int]:
    """Run ``lfd-track teach argv``, tap ``commands`` on its page, stop it with ``stop_signal``;
    returns (stdout, stderr, exit code). ``before(url, lines)`` runs once the printed URL is
    known, before the first tap."""
    proc, lines = start_teach(*argv)
    try:
        url = next(line.split("open ", 1)[1].strip() for line in lines if "open http" in line)
        if before is not None:
            before(url, lines)
        drive(loopback(url), commands)
        proc.send_signal(stop_signal)
        stdout, stderr = proc.communicate(timeout=WAIT_S)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    return stdout, stderr, proc.returncode


@pytest.mark.parametrize("stop_signal", [signal.SIGINT, signal.SIGTERM])
def test_ctrl_c_keeps_what_was_taught_for_evolve(tmp_path: Path, capsys, stop_signal) -> None:
    out = tmp_path / "taught.lfdemo"

    def token_guards_the_page(url: str, lines: list[str]) -> None:
        token = url.split("token=", 1)[1]
        assert len(token) >= 20 and "token in the URL is required" in "".join(lines)
        base = loopback(url).split("?")[0]
        assert http_status(base) == 403 and http_status(base + "api/status") == 403
        assert http_status(loopback(url)) == 200

    stdout, stderr, returncode = teach_and_stop(
        ["--out", str(out), "--host", "0.0.0.0"],
        ["forward", "forward", "left", "forward", "right"],
        stop_signal,
        before=token_guards_the_page,
    )
    assert returncode == 0, stderr
    assert f"{out}: 5 cases (3 forward, 1 left, 1 right)" in stdout
    demo = load_demonstration(out)
    assert demo.metadata["complete"] and demo.n_cases == 5
    assert demo.metadata["source"] == "teach" and "road_library" in demo.metadata
    controller = tmp_path / "controller.json"
    assert main(["evolve", str(out), "--generations", "3", "--out", str(controller)]) == 0
    assert controller.is_file() and "5 cases" in capsys.readouterr().out


def test_memory_inputs_are_recorded_and_evolve_into_a_memory_controller(tmp_path: Path) -> None:
    """``--memory last_bend``: each case carries the side of the last bend before it."""
    from lfd_track.policy.controller import Controller
    from lfd_track.policy.memory import LastBendConfig

    out = tmp_path / "taught.lfdemo"
    commands = ["left", "left", "forward", "right", "right", "forward"]
    _, stderr, returncode = teach_and_stop(["--out", str(out), "--memory", "last_bend"], commands)
    assert returncode == 0, stderr
    demo = load_demonstration(out)
    assert demo.metadata["memory"] == LastBendConfig().to_dict()
    assert demo.memory[:, 0].tolist() == [0.5, 0.5, 1.0, 1.0, 1.0, 0.0]
    controller = tmp_path / "controller.json"
    assert main(["evolve", str(out), "--generations", "3", "--out", str(controller)]) == 0
    assert Controller.load(controller).n_inputs == 41


def test_a_crash_keeps_every_case_already_given_for_evolve(tmp_path: Path, capsys) -> None:
    out = tmp_path / "taught.lfdemo"
    proc, lines = start_teach("--out", str(out))
    try:
        url = next(line.split("open ", 1)[1].strip() for line in lines if "open http" in line)
        assert "token" not in url  # loopback: no token needed
        drive(url, ["forward", "right", "forward"])
        proc.send_signal(signal.SIGKILL)  # no clean-up at all
        proc.communicate(timeout=WAIT_S)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    demo = load_demonstration(out)
    assert not demo.metadata["complete"]
    assert demo.commands.tolist() == [0, 2, 0]
    assert demo.metadata["road_library"]["types"]  # replayed from the library log
    controller = tmp_path / "controller.json"
    assert main(["evolve", str(out), "--generations", "3", "--out", str(controller)]) == 0
    assert controller.is_file() and "3 cases" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("argv", "problem"),
    [
        (["--backend", "hardware"], "needs --camera URL and --serial URL"),
        (["--camera", "http://127.0.0.1:1/video"], "are for --backend hardware"),
        (["--track", "no-such-track"], "no-such-track"),
        (
            ["--backend", "hardware", "--camera", "x.avi", "--serial", "socket://127.0.0.1:1"],
            "cannot open serial link",
        ),
    ],
)
def test_bad_arguments_are_one_line_errors(tmp_path: Path, capsys, argv, problem) -> None:
    code = main(["teach", "--port", "0", "--out", str(tmp_path / "t.lfdemo"), *argv])
    err = capsys.readouterr().err
    assert code == 1 and err.count("\n") == 1 and problem in err and "Traceback" not in err
    assert not (tmp_path / "t.lfdemo").exists()


def test_an_existing_file_is_not_replaced_without_force(tmp_path: Path, capsys) -> None:
    out = tmp_path / "t.lfdemo"
    out.write_bytes(b"keep me")
    assert main(["teach", "--port", "0", "--out", str(out)]) == 1
    assert "already exists" in capsys.readouterr().err and out.read_bytes() == b"keep me"
