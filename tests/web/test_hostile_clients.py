"""The teaching station against hostile clients: floods, bad messages, slow and idle connections.

The project's rule: a safety claim (stop, lease) holds under hostile load, not only on a quiet
link, and nothing a client sends hangs the server, crashes it with a traceback or starves other
clients. No browser: raw sockets, WebSocket clients in this process and flooders in others.
"""

from __future__ import annotations

import asyncio
import json
import logging
import re
import resource
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from lfd_test_support import wait_until
from websockets.exceptions import ConnectionClosed, InvalidStatus
from websockets.sync.client import connect

from lfd_track.cli import build_parser
from lfd_track.errors import LfdTrackError
from lfd_track.web import app as station_app
from lfd_track.web import guards as station_guards
from lfd_track.web import server as station_server
from lfd_track.web.app import MESSAGE_BURST, MESSAGE_RATE, StopLine, TokenBucket, create_app
from lfd_track.web.contract import HEARTBEAT_S, LEASE_S

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]
WAIT_S = 15.0  # failure guard only: every wait returns as soon as its condition holds
STOP_BOUND_S = 0.3
"""[s of this process's CPU time] the work the station does between a stop being sent and
carried out, however hard other pages flood.

On the fixed server a stop waits for at most one message of each other page (the loop is handed
on after each) plus a hop to the stop thread, which the loop hands the interpreter
(``StopLine.HAND_OVER_S``): a few milliseconds of work, counted from when the stop left the page
(:func:`send_stop`). 0.3 s leaves a margin of ten and more over that, and lies far below the seconds the unfixed server took (3.8-5.4 s in
the audit). It is counted in the process's CPU time (server, session and test threads), not on
the wall clock: on a machine whose cores other jobs hold, the wall clock also counts the time the
station waited for a core, which says nothing of its fairness. The wall clock keeps the safety
deadline, :data:`STOP_DEADLINE_S`."""
STOP_DEADLINE_S = LEASE_S
"""[s, wall clock] a stop is carried out within the page's lease (1 s), however hard other pages
flood and other jobs load the machine: the lease would stop the robot then anyway."""


def ws_url(station: Any) -> str:
    return station.url.replace("http", "ws", 1) + "ws"


def open_ws(station: Any) -> Any:
    return connect(ws_url(station), proxy=None, max_queue=None, open_timeout=WAIT_S)


def next_of(ws: Any, kind: str) -> dict[str, Any]:
    """The next text message of ``kind`` (``status`` or ``error``), skipping frames."""
    deadline = time.monotonic() + WAIT_S
    while time.monotonic() < deadline:
        message = ws.recv(timeout=WAIT_S)
        if isinstance(message, str) and (data := json.loads(message))["type"] == kind:
            return data
    raise AssertionError(f"no {kind} message in {WAIT_S} s")


def error_for(ws: Any, payload: str | bytes) -> str:
    ws.send(payload)
    return next_of(ws, "error")["message"]


def raw_ws(port: int, rcvbuf: int | None = None) -> socket.socket:
    """A WebSocket opened by hand (its frames are written raw); ``rcvbuf``: a small receive
    buffer, for a peer that reads nothing."""
    sock = socket.socket()
    if rcvbuf is not None:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, rcvbuf)
    sock.settimeout(WAIT_S)
    sock.connect(("127.0.0.1", port))
    sock.sendall(
        b"GET /ws HTTP/1.1\r\nHost: 127.0.0.1:%d\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
        b"Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n" % port
    )
    answer = b""
    while b"\r\n\r\n" not in answer:
        answer += sock.recv(1)
    assert answer.startswith(b"HTTP/1.1 101 "), answer
    return sock


def ws_frame(opcode: int, payload: bytes = b"", fin: bool = True) -> bytes:
    """One client frame of under 126 bytes (masked, with the all-zero key)."""
    return bytes([0x80 * fin | opcode, 0x80 | len(payload)]) + b"\0\0\0\0" + payload


PING, PONG, CONTINUATION, TEXT = 0x9, 0xA, 0x0, 0x1


@pytest.fixture
def server_log(capfd, caplog) -> Callable[[], str]:
    """``server_log()``: what the server logged during the test. uvicorn's loggers write to the
    standard error of the moment they are set up (each StationServer does), asyncio's go to
    pytest's log capture."""
    caplog.set_level(logging.WARNING, logger="asyncio")

    def text() -> str:
        asyncio_records = [r for r in caplog.records if r.name.startswith("asyncio")]
        return capfd.readouterr().err + "".join(
            f"{r.levelname}: {r.getMessage()}\n" for r in asyncio_records
        )

    return text


# ----------------------------------------------------------------------------- floods
class Flooder:
    """A ``flooder.py`` process; :attr:`closes` lists the server's closes as they happen."""

    def __init__(self, station: Any, kind: str) -> None:
        self.proc = subprocess.Popen(
            [sys.executable, str(HERE / "flooder.py"), ws_url(station), kind],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            text=True,
        )
        self.closes: list[str] = []
        self._lines: list[str] = []
        self._reader: threading.Thread | None = None

    def wait_flooding(self) -> None:
        first = self.proc.stdout.readline()
        assert first.strip() == "flooding", f"a flooder could not connect: {first!r}"
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        for line in self.proc.stdout:
            if line.startswith("closed "):
                self.closes.append(line.removeprefix("closed ").strip())
            self._lines.append(line)

    def stop(self) -> dict[str, Any]:
        """End the flooder (its standard input closes); its final report."""
        self.proc.stdin.close()
        self.proc.wait(timeout=WAIT_S)
        if self._reader is not None:
            self._reader.join(WAIT_S)
        return json.loads(self._lines[-1])

    def kill(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.communicate()


def start_flooders(station: Any, kinds: list[str]) -> list[Flooder]:
    """One flooder process per kind, each flooding once this returns."""
    flooders = [Flooder(station, kind) for kind in kinds]
    for flooder in flooders:
        flooder.wait_flooding()
    return flooders


def stop_flooders(flooders: list[Flooder]) -> list[dict[str, Any]]:
    return [flooder.stop() for flooder in flooders]


class Heartbeats:
    """Sends a heartbeat on ``ws`` every HEARTBEAT_S from a thread of its own, as the page does
    while it is open (a page silent for a lease loses control to the next page that claims it)."""

    def __init__(self, ws: Any) -> None:
        self._ws = ws
        self._done = threading.Event()
        self._thread = threading.Thread(target=self._beat, daemon=True)

    def __enter__(self) -> Heartbeats:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._done.set()
        self._thread.join(WAIT_S)

    def _beat(self) -> None:
        while not self._done.wait(HEARTBEAT_S):
            try:
                self._ws.send(json.dumps({"type": "heartbeat"}))
            except ConnectionClosed:
                return  # the test fails on the page's own use of the connection


def latest_status(ws: Any) -> dict[str, Any]:
    """A status message sent after this call: what is already queued is read past first."""
    while True:
        try:
            ws.recv(timeout=0)
        except TimeoutError:
            break
    return next_of(ws, "status")


def _clocks() -> tuple[float, float]:
    """(wall clock, this process's CPU time) now."""
    return time.monotonic(), time.process_time()


def send_stop(controller: Any) -> tuple[float, float]:
    """Press stop on ``controller``; the clocks (:func:`_clocks`) once the message is on its way
    to the server (its socket took it). The server's latency counts from there: the page runs in
    this process too, and its own wait for the interpreter lock (which the flooded server thread
    holds for a few milliseconds at a time) is not the server's."""
    controller.send(json.dumps({"type": "stop"}))
    return _clocks()


def _since(start: tuple[float, float], end: tuple[float, float]) -> tuple[float, float]:
    return end[0] - start[0], end[1] - start[1]


def _assert_stops_in_time(latencies: list[tuple[float, float]]) -> None:
    """Each (wall, CPU) latency within STOP_DEADLINE_S and STOP_BOUND_S."""
    wall, cpu = [round(w, 4) for w, _ in latencies], [round(c, 4) for _, c in latencies]
    print(f"stop latencies: wall {wall} s, CPU {cpu} s")
    assert max(cpu) < STOP_BOUND_S, cpu
    assert max(wall) < STOP_DEADLINE_S, wall


def time_stop_buttons(session) -> list[tuple[float, float]]:
    """Wrap ``session.stop``: the returned list gets the clocks (:func:`_clocks`) when each
    stop-button stop was done."""
    done: list[tuple[float, float]] = []
    real_stop = session.stop

    def timed_stop(reason: str = "stop") -> None:
        real_stop(reason)
        if "stop button" in reason.split(StopLine.REASON_SEPARATOR):
            done.append(_clocks())

    session.stop = timed_stop
    return done


@pytest.mark.parametrize("limited", [True, False], ids=["rate-limited", "no-rate-limit"])
def test_a_stop_wins_under_a_flood_from_other_pages(open_station, server_log, limited) -> None:
    """Four other pages flood (bad JSON and heartbeats, reconnecting whenever closed); each stop
    of the controlling page is still carried out within STOP_BOUND_S. Without the rate limit
    too: handing the loop on after each message is enough for that. With it, every flooder is
    closed with 1008 (and reconnects, to be closed again).

    The controlling page sends its heartbeats throughout, as the page does: one silent for a
    lease (starting four flooder processes on a loaded machine takes that long) loses control to
    a flooder, whose close then asks for a stop that the next stop button joins."""
    station = open_station(app_options={} if limited else {"message_rate": None})
    done = time_stop_buttons(station.session)
    flooders: list[Flooder] = []
    try:
        with open_ws(station) as controller, Heartbeats(controller):
            assert next_of(controller, "status")["role"] == "controller"
            flooders = start_flooders(station, ["junk", "junk", "heartbeat", "heartbeat"])
            latencies = []
            for given in range(1, 6):
                time.sleep(0.1)  # a stop now and then, amid the flood
                sent = send_stop(controller)
                wait_until(lambda given=given: len(done) >= given, "the stop")
                latencies.append(_since(sent, done[given - 1]))
            if limited:
                # The limit closes a page once the app took more than MESSAGE_BURST of its
                # messages plus MESSAGE_RATE a second: however slowly a loaded server takes
                # them, each flooder gets there (WAIT_S is a failure guard, not a deadline).
                wait_until(lambda: all(f.closes for f in flooders), "every flooder closed")
            reports = stop_flooders(flooders)
            # The controlling page sent little: it is still connected, and still in control.
            assert latest_status(controller)["role"] == "controller"
    finally:
        for flooder in flooders:
            flooder.kill()
    print("flooders:", reports)
    _assert_stops_in_time(latencies)
    if limited:
        for report in reports:
            assert report["closes"], report
            assert all(key.startswith("1008 too many messages") for key in report["closes"])
    log = server_log()
    assert "ERROR" not in log and "Traceback" not in log, log


def test_a_page_that_floods_is_closed_with_1008(open_station) -> None:
    station = open_station()
    with open_ws(station) as ws:
        with pytest.raises(ConnectionClosed) as closed:
            for _ in range(MESSAGE_BURST * 3):
                ws.send("{bad")
            deadline = time.monotonic() + WAIT_S
            while time.monotonic() < deadline:
                ws.recv(timeout=WAIT_S)
    assert closed.value.rcvd.code == 1008
    assert "too many messages" in closed.value.rcvd.reason
    with open_ws(station) as ws:  # the server serves on
        assert next_of(ws, "status")["type"] == "status"


def test_the_message_limit_is_far_above_what_the_page_sends() -> None:
    # Heartbeats plus a press and a release for ten button pushes a second, four times over.
    assert 4 * (1 / HEARTBEAT_S + 2 * 10) <= MESSAGE_RATE
    assert MESSAGE_BURST >= 2 * MESSAGE_RATE


def test_the_token_bucket_allows_a_burst_then_its_rate() -> None:
    now = [0.0]
    bucket = TokenBucket(rate=10.0, burst=5, clock=lambda: now[0])
    assert [bucket.take() for _ in range(6)] == [True] * 5 + [False]
    now[0] += 0.1  # one more token
    assert bucket.take() and not bucket.take()
    now[0] += 100.0  # never more than the burst
    assert sum(bucket.take() for _ in range(10)) == 5


def test_pages_beyond_the_limit_are_refused_cleanly(open_station, server_log) -> None:
    station = open_station(app_options={"max_pages": 2})
    with open_ws(station) as first, open_ws(station):
        with pytest.raises(InvalidStatus) as refused:
            with open_ws(station):
                pass
        assert refused.value.response.status_code == 503
        assert b"pages are open" in refused.value.response.body
        first.close()
        wait_until(lambda: _can_open(station), "a page to be let in again")
    log = server_log()
    assert not log, log


def _can_open(station: Any) -> bool:
    try:
        with open_ws(station) as ws:
            return next_of(ws, "status")["type"] == "status"
    except InvalidStatus:
        return False


def _flood_in_background(sock: socket.socket, frame: bytes, count: int) -> Callable[[], None]:
    """Send ``frame`` ``count`` times in one write, over and over, reading whatever comes back,
    from a process of its own (``raw_flooder.py``), until the returned function is called (it
    ends the flooder and closes ``sock``)."""
    proc = subprocess.Popen(
        [sys.executable, str(HERE / "raw_flooder.py"), str(sock.fileno()), frame.hex(), str(count)],
        pass_fds=[sock.fileno()],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
    )
    assert proc.stdout.readline().strip() == "flooding"

    def end() -> None:
        proc.communicate(timeout=WAIT_S)  # closes stdin: the flooder stops
        sock.close()

    return end


@pytest.mark.parametrize("opcode", [PING, PONG, CONTINUATION], ids=["ping", "pong", "continuation"])
def test_frames_that_make_no_message_cannot_hold_up_a_stop(open_station, opcode) -> None:
    """Pings, pongs and continuation frames never reach the app (nor its message budget): a page
    flooding them must still be parsed a slice per turn of the event loop, so the controlling
    page's stop is carried out within STOP_BOUND_S."""
    station = open_station()
    done = time_stop_buttons(station.session)
    with open_ws(station) as controller:
        assert next_of(controller, "status")["role"] == "controller"
        flooder = raw_ws(station.server.port)
        start = ws_frame(TEXT, b"{", fin=False) if opcode == CONTINUATION else b""
        flooder.sendall(start)
        frame = ws_frame(opcode, fin=opcode != CONTINUATION)
        end_flood = _flood_in_background(flooder, frame, 50_000)
        try:
            latencies = []
            for given in range(1, 6):
                time.sleep(0.1)
                controller.send(json.dumps({"type": "heartbeat"}))
                sent = send_stop(controller)
                wait_until(lambda given=given: len(done) >= given, "the stop")
                latencies.append(_since(sent, done[given - 1]))
        finally:
            end_flood()
    _assert_stops_in_time(latencies)


def _closed_by_server(ws: Any, timeout_s: float = 5.0) -> Any:
    """The close frame the server sent ``ws`` within ``timeout_s`` (reading what comes first)."""
    deadline = time.monotonic() + timeout_s
    try:
        while time.monotonic() < deadline:
            ws.recv(timeout=max(0.01, deadline - time.monotonic()))
    except ConnectionClosed as closed:
        return closed.rcvd
    except TimeoutError:
        pass
    raise AssertionError(f"the server did not close the WebSocket in {timeout_s} s")


def test_a_message_in_endless_fragments_is_refused(open_station, server_log) -> None:
    """Empty continuation frames add nothing to a message's size: without a cap on their number
    a page could grow the server's memory without end."""
    station = open_station()
    with open_ws(station) as ws:
        try:
            ws.send(["{"] + [""] * 20_000 + ["}"])
        except ConnectionClosed:
            pass  # closed already, while still sending
        rcvd = _closed_by_server(ws)
    assert rcvd is not None and rcvd.code == 1009, rcvd
    assert _can_open(station)  # the server serves on
    log = server_log()
    assert "ERROR" not in log and "Traceback" not in log, log


def test_a_failed_stop_after_the_controlling_page_closed_is_logged(open_station, server_log):
    """When the controlling page goes, the robot is stopped; if that stop fails (the serial link
    is gone) the failure is logged, not dropped in a thread nobody asks."""
    station = open_station()

    def failing_stop(reason: str = "stop") -> None:
        raise LfdTrackError(f"serial link lost (stopping: {reason})")

    station.session.stop = failing_stop
    with open_ws(station) as ws:
        assert next_of(ws, "status")["role"] == "controller"
    seen: list[str] = []
    wait_until(
        lambda: seen.append(server_log()) or "serial link lost" in "".join(seen),
        "the failed stop to be logged",
        timeout_s=5.0,
    )
    assert "the controlling page closed" in "".join(seen)


def _line_whose_first_stop_waits() -> tuple[StopLine, list[str], threading.Event]:
    """A stop line, the reasons its stops ran for, and the event that ends the stop asked for
    with reason "first" (it runs until the event is set)."""
    release = threading.Event()
    calls: list[str] = []

    def stop(reason: str) -> None:
        calls.append(reason)
        if reason == "first":
            release.wait(WAIT_S)

    return StopLine(stop), calls, release


def test_a_cancelled_wait_for_a_stop_neither_drops_it_nor_breaks_later_stops() -> None:
    """A page waiting for its stop may be cancelled (the server shutting down): the stop it
    asked for still runs, and the stops asked for afterwards run too."""
    line, calls, release = _line_whose_first_stop_waits()

    async def main() -> None:
        line.request("first")
        wait_until(lambda: calls == ["first"], "the first stop to start")
        waiter = asyncio.create_task(line.stop("second"))  # queued behind the first
        await asyncio.sleep(0.01)
        waiter.cancel()
        await asyncio.gather(waiter, return_exceptions=True)
        release.set()
        await asyncio.to_thread(wait_until, lambda: len(calls) == 2, "the second stop", 5.0)
        await asyncio.wait_for(line.stop("third"), WAIT_S)

    asyncio.run(main())
    assert calls == ["first", "second", "third"]


def test_only_a_stop_that_can_start_at_once_holds_the_event_loop(monkeypatch) -> None:
    """The event loop waits, blocked, for a stop that can start at once (so a busy loop cannot
    starve the stop's thread of the interpreter), and for at most HAND_OVER_S: a stop that hangs
    holds it no longer, and the stops asked for while it runs do not block the loop at all."""
    waits: list[float] = []
    real_wait = station_app.wait

    def recorded_wait(futures: Any, timeout: float) -> Any:
        waits.append(timeout)
        return real_wait(futures, timeout=timeout)

    monkeypatch.setattr(station_app, "wait", recorded_wait)
    line, calls, release = _line_whose_first_stop_waits()

    async def main() -> None:
        first = asyncio.create_task(line.stop("first"))
        await asyncio.to_thread(wait_until, lambda: calls == ["first"], "the first stop", 5.0)
        assert waits == [StopLine.HAND_OVER_S] and not first.done()  # it hangs: the loop went on
        second = asyncio.create_task(line.stop("second"))
        third = asyncio.create_task(line.stop("third"))  # joins the second
        await asyncio.sleep(0.01)
        assert waits == [StopLine.HAND_OVER_S]
        release.set()
        await asyncio.wait_for(asyncio.gather(first, second, third), WAIT_S)
        await asyncio.wait_for(line.stop("fourth"), WAIT_S)  # the line is idle again

    asyncio.run(main())
    assert calls == ["first", "second; third", "fourth"]
    assert waits == [StopLine.HAND_OVER_S] * 2


def test_a_stop_that_joins_a_waiting_one_names_both_reasons() -> None:
    """The controlling page closes (its stop waits behind a running one) and a stop button is
    pressed: one stop runs for both, after both were asked for, and carries both reasons."""
    line, calls, release = _line_whose_first_stop_waits()
    running = line.request("first")
    wait_until(lambda: calls == ["first"], "the first stop to start")
    closing = line.request("the controlling page closed")
    pressed = line.request("stop button")
    again = line.request("stop button")
    assert closing is pressed is again
    release.set()
    pressed.result(WAIT_S)
    assert running.done()
    assert calls == ["first", "the controlling page closed; stop button"]
    line.request("stop button").result(WAIT_S)  # the next one runs on its own
    assert calls[-1] == "stop button"


@pytest.mark.parametrize(
    "options", [{"message_rate": 0}, {"message_burst": 0}, {"message_rate": float("nan")}]
)
def test_bad_message_limits_are_refused_when_the_app_is_made(options) -> None:
    """Not at each page's connection, after the page was counted (each would then hold its
    place for good, and the station refuse every page after MAX_PAGES of them)."""
    with pytest.raises(ValueError, match="rate > 0 and burst >= 1"):
        create_app(object(), **options)  # type: ignore[arg-type]


# ----------------------------------------------------------------------------- bad messages
@pytest.fixture
def controller(open_station, server_log) -> Iterator[tuple[Any, Any]]:
    """``(station, ws)``: a station and its controlling page's raw WebSocket; once the test is
    done the page still drives (its connection was kept) and the server logged nothing."""
    station = open_station()
    with open_ws(station) as ws:
        assert next_of(ws, "status")["role"] == "controller"
        yield station, ws
        ws.send(json.dumps({"type": "press", "command": "forward"}))
        ws.send(json.dumps({"type": "release"}))
        wait_until(lambda: station.session.status()["cases"] == 1, "the command")
    log = server_log()
    assert not log, log


def test_deeply_nested_json_gets_an_error_reply(controller) -> None:
    _, ws = controller
    assert error_for(ws, "[" * 2000 + "]" * 2000) == "message nested too deeply"
    assert "too long" in error_for(ws, "[" * 100_000 + "]" * 100_000)
    assert "not JSON" in error_for(ws, "{bad")
    assert "JSON object" in error_for(ws, "[1, 2]")


def test_binary_messages_are_refused_by_name(controller) -> None:
    _, ws = controller
    assert error_for(ws, b"\x00binary") == "binary messages are not accepted"


def test_error_replies_quote_only_the_start_of_a_bad_value(controller) -> None:
    _, ws = controller
    message = error_for(ws, json.dumps({"type": "press", "command": "x" * 5000}))
    assert message.startswith("unknown command 'xxx") and len(message) < 100, message
    message = error_for(ws, json.dumps({"type": ["y"] * 1000}))
    assert message.startswith("unknown message type ['y'") and len(message) < 100, message


def test_pause_learning_needs_a_json_boolean(controller) -> None:
    station, ws = controller
    session = station.session
    for paused in ("false", "true", 0, 1, None):  # the string "false" is not false (nor true)
        message = error_for(ws, json.dumps({"type": "pause-learning", "paused": paused}))
        assert "true or false" in message, message
        assert session.status()["learning_paused"] is False
    ws.send(json.dumps({"type": "pause-learning", "paused": True}))
    wait_until(lambda: session.status()["learning_paused"], "learning paused")
    ws.send(json.dumps({"type": "pause-learning", "paused": False}))
    wait_until(lambda: not session.status()["learning_paused"], "learning resumed")


# ----------------------------------------------------------------------------- HTTP
def raw_request(port: int, request: bytes) -> bytes:
    with socket.create_connection(("127.0.0.1", port), timeout=WAIT_S) as sock:
        sock.sendall(request)
        answer = b""
        while chunk := sock.recv(65536):
            answer += chunk
    return answer


def test_malformed_host_and_origin_are_refused_without_a_traceback(
    open_station, server_log
) -> None:
    station = open_station()
    port = station.server.port
    answer = raw_request(port, b"GET / HTTP/1.1\r\nHost: [::1\r\nConnection: close\r\n\r\n")
    assert answer.startswith(b"HTTP/1.1 400 "), answer[:200]
    assert b"malformed Host header" in answer
    upgrade = (
        b"GET /ws HTTP/1.1\r\nHost: 127.0.0.1:%d\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
        b"Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n"
        b"Origin: http://[zz\r\n\r\n" % port
    )
    assert raw_request(port, upgrade).startswith(b"HTTP/1.1 403 ")
    host_upgrade = upgrade.replace(b"Host: 127.0.0.1:%d" % port, b"Host: [::1").replace(
        b"Origin: http://[zz\r\n", b""
    )
    assert raw_request(port, host_upgrade).startswith(b"HTTP/1.1 400 ")
    assert station.session.status()["steps"] == 0
    log = server_log()
    assert not log, log


def _is_closed(sock: socket.socket) -> bool:
    """True once the server closed ``sock`` (whatever it said first)."""
    sock.setblocking(False)
    try:
        while chunk := sock.recv(65536):
            del chunk
        return True
    except BlockingIOError:
        return False
    except OSError:
        return True


def test_slow_and_idle_connections_are_closed_and_capped(open_station, server_log) -> None:
    """Half-sent requests are closed after the header deadline; at the connection limit a new
    connection takes the place of the oldest one still owing its headers, so a real request
    gets through a slow-loris attack."""
    station = open_station(server_options={"header_timeout_s": 1.0, "max_connections": 8})
    port = station.server.port
    partial = b"GET /api/status HTTP/1.1\r\nHost: 127.0.0.1\r\nX-a: "
    held = []
    opened_at = time.monotonic()
    for _ in range(30):
        sock = socket.create_connection(("127.0.0.1", port), timeout=WAIT_S)
        sock.sendall(partial)
        held.append(sock)
    # A keep-alive connection that sends half of its second request is no better.
    keep_alive = socket.create_connection(("127.0.0.1", port), timeout=WAIT_S)
    keep_alive.sendall(b"GET /api/status HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n")
    assert keep_alive.recv(65536).startswith(b"HTTP/1.1 200 ")
    keep_alive.sendall(partial)
    held.append(keep_alive)
    # A real request meanwhile is served.
    answer = raw_request(port, b"GET /api/status HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n")
    assert answer.startswith(b"HTTP/1.1 200 ") and b'"cases"' in answer
    try:
        wait_until(lambda: all(_is_closed(s) for s in held), "the server to close them all")
        closed_after = time.monotonic() - opened_at
    finally:
        for sock in held:
            sock.close()
    assert closed_after < 1.0 + 2.0, f"closed after {closed_after:.2f} s (deadline 1 s)"
    assert station.server.max_connections == 8
    log = server_log()
    assert "ERROR" not in log and "Traceback" not in log, log


def _served(port: int) -> bool:
    """True when a status request is answered 200 (not refused: 503, or reset unread)."""
    try:
        answer = raw_request(port, b"GET /api/status HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n")
    except ConnectionResetError:
        return False
    return answer.startswith(b"HTTP/1.1 200 ")


STALL_SLACK_S = 1.5
"""[s, the server's own clock] how late a stalled connection may be dropped after
WRITE_STALL_S: the event loop runs a timer late by as long as its other work and the machine
hold it up (on a loaded 2-core machine: tens to hundreds of milliseconds)."""


def _stall_times(monkeypatch) -> dict[int, list[float]]:
    """``{id(connection): [writes stalled, connection lost]}`` in the server's monotonic time,
    taken by the server's event loop as the events happen (not when the test looks)."""
    times: dict[int, list[float]] = {}
    pause, lost = station_guards.Connection.pause_writing, station_guards.Connection.connection_lost

    def timed_pause(self) -> None:
        times.setdefault(id(self), [time.monotonic()])
        pause(self)

    def timed_lost(self, exc) -> None:
        if id(self) in times:
            times[id(self)].append(time.monotonic())
        lost(self, exc)

    monkeypatch.setattr(station_guards.Connection, "pause_writing", timed_pause)
    monkeypatch.setattr(station_guards.Connection, "connection_lost", timed_lost)
    return times


def test_a_client_that_reads_no_responses_cannot_hold_connections(
    open_station, server_log, monkeypatch
) -> None:
    """Clients that pipeline requests and never read the responses hold connections that owe
    no headers (so none makes room for a new one) until their writes stall for WRITE_STALL_S:
    then they are dropped, as stalled WebSockets are, and the station serves again. The drop's
    deadline is asserted in the server's own time (when its loop saw the stall and the loss)."""
    monkeypatch.setattr(station_guards, "WRITE_STALL_S", 1.0)
    times = _stall_times(monkeypatch)
    station = open_station(server_options={"max_connections": 8})
    port = station.server.port
    held = []
    try:
        for _ in range(8):
            sock = socket.socket()
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1024)
            sock.connect(("127.0.0.1", port))
            sock.sendall(b"GET /static/app.js HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n" * 400)
            held.append(sock)
        guard = station.server._guard
        wait_until(lambda: len(guard.open) == 8 and not guard.waiting, "their requests")
        # They hold every place and none owes its headers: a request is refused unless a
        # stalled one was already dropped (WRITE_STALL_S can pass before this line under load).
        if _served(port):
            assert any(len(t) == 2 for t in times.values()), "served while 8 places were held"
        wait_until(lambda: _served(port), "a request to be served again")
    finally:
        for sock in held:
            sock.close()
    dropped = [t for t in times.values() if len(t) == 2]
    assert dropped, times
    for stalled_at, lost_at in dropped:
        assert 1.0 <= lost_at - stalled_at < 1.0 + STALL_SLACK_S, lost_at - stalled_at
    log = server_log()
    assert "ERROR" not in log and "Traceback" not in log, log


def test_a_closed_websocket_whose_peer_reads_nothing_is_dropped(
    open_station, server_log, monkeypatch
) -> None:
    """The server closes a flooding page (1008) while a few of its messages to the page wait,
    unread, in the server's write buffer (too few to stall the writes): a close that cannot
    flush must not hold the connection, and its place under MAX_CONNECTIONS, for good."""
    monkeypatch.setattr(station_guards, "WRITE_STALL_S", 60.0)  # only the close may drop it
    station = open_station()
    station.session.latest_view = lambda: None  # status messages only: the buffer grows slowly
    station.server.sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, 4096)  # fills sooner
    guard = station.server._guard
    sock = raw_ws(station.server.port, rcvbuf=1024)
    try:
        (transport,) = wait_until(lambda: list(guard.open), "the page to be open")
        wait_until(lambda: transport.get_write_buffer_size() > 0, "the page to stop reading")
        assert transport.get_write_buffer_size() < 16_384  # far below the high-water mark
        heartbeat = ws_frame(TEXT, json.dumps({"type": "heartbeat"}).encode())
        sock.sendall(heartbeat * (MESSAGE_BURST + 100))
        # Closed one grace after the 1008 close frame: uvicorn alone would wait 10 s for a close
        # reply, which a peer that reads nothing never sends (5 s: the flood's 400 messages are
        # answered first, on a loaded machine too).
        wait_until(
            transport.is_closing,
            "the server to close the page",
            timeout_s=station_guards.CLOSE_GRACE_S + 5.0,
        )
        wait_until(
            lambda: not guard.open,
            "the closed page to be dropped",
            timeout_s=station_guards.CLOSE_GRACE_S + 3.0,
        )
    finally:
        sock.close()
    log = server_log()
    assert "ERROR" not in log and "Traceback" not in log, log


def test_the_station_runs_on_the_asyncio_loop() -> None:
    """server.py relies on asyncio's selector loop (its accept-error message, its 256 KiB reads,
    its transports' flow control); uvicorn's "auto" would pick uvloop wherever it is installed."""
    sock = station_server.bind_socket("127.0.0.1", 0)
    try:
        server = station_server.StationServer(object(), sock)
        assert server._server.config.loop == "asyncio"
        loop = server.new_loop()
        try:
            assert isinstance(loop, asyncio.SelectorEventLoop)
        finally:
            loop.close()
    finally:
        sock.close()


def test_running_out_of_file_descriptors_is_logged_once_not_per_accept() -> None:
    records: list[logging.LogRecord] = []
    handler = logging.Handler(logging.WARNING)
    handler.emit = records.append  # type: ignore[method-assign]
    station_server._log.addHandler(handler)
    guard = station_guards.Guard(limit=8, header_timeout_s=1.0)
    loop = asyncio.new_event_loop()
    try:
        loop.set_exception_handler(guard.loop_exception)
        for _ in range(5000):
            loop.call_exception_handler(
                {
                    "message": "socket.accept() out of system resource",
                    "exception": OSError(24, "Too many open files"),
                }
            )
    finally:
        loop.close()
        station_server._log.removeHandler(handler)
    assert len(records) == 1 and "Too many open files" in records[0].getMessage()
    assert records[0].exc_info is None  # one line, no traceback


def test_a_connection_flood_cannot_exhaust_file_descriptors(tmp_path: Path) -> None:
    """``lfd-track teach`` allowed 256 open files holds fewer connections than that: 600 idle
    ones are refused or closed, nothing about file descriptors is logged, it serves on."""

    def low_file_limit() -> None:
        hard = resource.getrlimit(resource.RLIMIT_NOFILE)[1]
        resource.setrlimit(resource.RLIMIT_NOFILE, (256, hard))

    proc = subprocess.Popen(
        [sys.executable, "-m", "lfd_track.cli", "teach", "--port", "0", "--out",
         str(tmp_path / "t.lfdemo")],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=REPO,
        preexec_fn=low_file_limit,
    )  # fmt: skip
    socks: list[socket.socket] = []
    try:
        lines = [proc.stdout.readline() for _ in range(3)]
        port = int(re.search(r":(\d+)/", lines[0]).group(1))
        for _ in range(600):  # all at once, without waiting for each to be accepted
            sock = socket.socket()
            sock.setblocking(False)
            sock.connect_ex(("127.0.0.1", port))
            socks.append(sock)
        answer = raw_request(port, b"GET /api/status HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n")
        assert answer.startswith(b"HTTP/1.1 200 "), answer[:100]
    finally:
        for sock in socks:
            sock.close()
        proc.terminate()
        _, stderr = proc.communicate(timeout=WAIT_S)
    assert "Too many open files" not in stderr and "Traceback" not in stderr, stderr[-2000:]
    assert stderr.count("\n") <= 3, stderr[-2000:]


# ----------------------------------------------------------------------------- options
@pytest.mark.parametrize(
    ("option", "value"),
    [("--fps", "1e-320"), ("--fps", "1000"), ("--period", "1e-320"), ("--period", "1e9")],
)
def test_out_of_range_rates_are_one_line_errors(tmp_path: Path, capsys, option, value) -> None:
    out = tmp_path / "t.lfdemo"
    with pytest.raises(SystemExit) as exited:  # the parser alone: nothing starts serving
        build_parser().parse_args(["teach", "--out", str(out), option, value])
    err = capsys.readouterr().err
    assert exited.value.code == 2 and err.count("\n") == 1, err
    assert option in err and "must be in" in err


def test_the_default_limits_are_sane() -> None:
    from lfd_track.cli.teach import PERIOD_RANGE
    from lfd_track.envs.presets import BOUNDS

    assert PERIOD_RANGE == BOUNDS["rover.control_period_s"]
    assert 1.0 <= station_server.HEADER_TIMEOUT_S <= 10.0
    assert station_server.MAX_CONNECTIONS <= 512
    assert station_app.MAX_PAGES * 4 <= station_server.MAX_CONNECTIONS
