"""The connection guards of ``lfd_track/web/guards.py`` on their own: how a WebSocket's frames
are followed, that a connection that sent its headers is not held to the header deadline, and
that a WebSocket is read only as fast as the app takes its messages.

(The hostile-client tests, ``test_hostile_clients.py``, show them against the station.)
"""

from __future__ import annotations

import asyncio
import socket
import threading
from collections.abc import Iterator
from typing import Any

import pytest
from lfd_test_support import wait_until

from lfd_track.web import guards
from lfd_track.web.server import StationServer, bind_socket

WAIT_S = 15.0


def _frame(opcode: int, payload: bytes = b"", fin: bool = True) -> bytes:
    """A masked client frame (all-zero key), with the extended lengths when needed."""
    head = bytes([0x80 * fin | opcode])
    if len(payload) < 126:
        head += bytes([0x80 | len(payload)])
    elif len(payload) < 1 << 16:
        head += bytes([0x80 | 126]) + len(payload).to_bytes(2, "big")
    else:
        head += bytes([0x80 | 127]) + len(payload).to_bytes(8, "big")
    return head + b"\0\0\0\0" + payload


TEXT, BINARY, CONTINUATION, PING, PONG, CLOSE = 0x1, 0x2, 0x0, 0x9, 0xA, 0x8


def test_frames_are_counted_as_messages_across_any_split() -> None:
    stream = (
        _frame(TEXT, b"a")
        + _frame(PING, b"p")
        + _frame(BINARY, b"x" * 300)  # a 2-byte extended length
        + _frame(TEXT, b"{", fin=False)
        + _frame(PONG)
        + _frame(CONTINUATION, b"y" * 70_000, fin=False)  # an 8-byte extended length
        + _frame(CONTINUATION, b"}")
        + _frame(CLOSE, b"\x03\xe8")
    )
    for cut in [*range(0, 40), len(stream) // 2, len(stream) - 1]:
        frames = guards.Frames()
        assert frames.scan(stream[:cut]) is None and frames.scan(stream[cut:]) is None
        assert frames.messages == 3, cut
    frames = guards.Frames()
    for byte in range(len(stream)):
        assert frames.scan(stream[byte : byte + 1]) is None
    assert frames.messages == 3


def test_a_message_in_too_many_frames_is_caught_at_the_frame_over_the_limit() -> None:
    first = _frame(TEXT, b"{", fin=False)
    more = _frame(CONTINUATION, fin=False)
    frames = guards.Frames()
    allowed = first + more * (guards.MAX_FRAGMENTS - 1)
    assert frames.scan(_frame(TEXT, b"ok") + allowed) is None and frames.messages == 1
    ping = _frame(PING)
    assert frames.scan(ping + more) == len(ping)  # a ping, then the frame over the limit
    frames = guards.Frames()
    assert frames.scan(first + more * (guards.MAX_FRAGMENTS - 2) + _frame(CONTINUATION)) is None
    assert frames.messages == 1  # 64 frames in all: allowed


class _SlowApp:
    """An ASGI app whose WebSocket takes no message until ``release`` is set, then all."""

    def __init__(self) -> None:
        self.release = threading.Event()
        self.received: list[str] = []

    async def __call__(self, scope: dict[str, Any], receive: Any, send: Any) -> None:
        if scope["type"] == "http":
            await send({"type": "http.response.start", "status": 200, "headers": []})
            await send({"type": "http.response.body", "body": b"ok"})
            return
        assert scope["type"] == "websocket"
        await receive()  # websocket.connect
        await send({"type": "websocket.accept"})
        while not self.release.is_set():
            await asyncio.sleep(0.01)  # the app's own pace: busy elsewhere
        while (message := await receive())["type"] == "websocket.receive":
            self.received.append(message["text"])


@pytest.fixture
def slow_station() -> Iterator[tuple[StationServer, _SlowApp]]:
    app = _SlowApp()
    server = StationServer(app, bind_socket("127.0.0.1", 0), header_timeout_s=0.5).start()
    try:
        yield server, app
    finally:
        app.release.set()
        server.shutdown()


def _open_raw_ws(port: int) -> socket.socket:
    sock = socket.create_connection(("127.0.0.1", port), timeout=WAIT_S)
    sock.sendall(
        b"GET /ws HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
        b"Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n"
    )
    answer = b""
    while b"\r\n\r\n" not in answer:
        answer += sock.recv(1)
    assert answer.startswith(b"HTTP/1.1 101 "), answer
    return sock


def _connection(server: StationServer) -> guards.Connection:
    (connection,) = wait_until(lambda: list(server._guard.by_address.values()), "the connection")
    return connection


def test_a_websocket_is_read_only_as_fast_as_the_app_takes_its_messages(slow_station) -> None:
    server, app = slow_station
    sock = _open_raw_ws(server.port)
    try:
        connection = _connection(server)
        count = 3000
        sock.sendall(b"".join(_frame(TEXT, b"%d" % i) for i in range(count)))
        # Handing on stops at the queue limit while most of the flood still waits, unread.
        wait_until(
            lambda: connection._unparsed and connection._next_slice is None,
            "handing on to pause",
        )
        slice_messages = guards.READ_SLICE_BYTES // len(_frame(TEXT, b"0"))
        assert connection._frames.messages <= guards.MAX_QUEUED_MESSAGES + slice_messages
        app.release.set()
        wait_until(lambda: len(app.received) == count, "the app to take every message")
        assert app.received == [str(i) for i in range(count)]  # none lost, in order
    finally:
        sock.close()


def test_the_header_deadline_holds_for_requests_not_for_an_open_websocket(slow_station) -> None:
    """The header deadline (0.5 s here) runs from connecting and from each response to the next
    request's headers (an idle keep-alive connection is closed by it), never once a WebSocket
    is open."""
    server, app = slow_station
    ws = _open_raw_ws(server.port)
    ws_connection = _connection(server)
    http = socket.create_connection(("127.0.0.1", server.port), timeout=WAIT_S)
    try:
        assert ws_connection not in server._guard.waiting
        http.sendall(b"GET / HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n")
        answer = b""
        while not answer.endswith(b"0\r\n\r\n"):  # the chunked body's end
            answer += http.recv(65536)
        assert answer.startswith(b"HTTP/1.1 200 ")
        assert http.recv(65536) == b""  # closed by the server: no next request in time
        # Well past the deadline (a bounded look: nothing is waited for here).
        threading.Event().wait(4 * server._guard.header_timeout_s)
        assert ws_connection.transport in server._guard.open
        assert not ws_connection.transport.is_closing()
    finally:
        ws.close()
        http.close()


class _Transport(asyncio.Transport):
    """A socket's transport as far as admission and eviction look at it."""

    def __init__(self) -> None:
        super().__init__()
        self.closed = False

    def get_extra_info(self, name: str, default: Any = None) -> Any:
        return default

    def write(self, data: Any) -> None:
        pass

    def close(self) -> None:
        self.closed = True

    def abort(self) -> None:
        self.closed = True

    def is_closing(self) -> bool:
        return self.closed

    def get_write_buffer_size(self) -> int:
        return 0

    def pause_reading(self) -> None:
        pass

    def resume_reading(self) -> None:
        pass


class _Protocol(asyncio.Protocol):
    """uvicorn's HTTP protocol as far as the guard drives it: it has not called the app yet."""

    def data_received(self, data: bytes) -> None:
        pass


def test_a_connection_whose_request_came_in_is_not_evicted_before_the_app_sees_it() -> None:
    """At the limit, a new connection takes the place of the oldest one still owing its request:
    one whose request head has been read is not that one, even while the app has not been
    called yet (under load, turns of the event loop in which a flood is accepted)."""

    async def admit_three() -> list[_Transport]:
        guard = guards.Guard(limit=2, header_timeout_s=60.0)
        transports = [_Transport() for _ in range(3)]
        first = guards.Connection(_Protocol, guard)
        first.connection_made(transports[0])
        first.data_received(b"GET /api/status HTTP/1.1\r\n")  # the head, split across reads
        first.data_received(b"Host: 127.0.0.1\r\n\r\n")
        for transport in transports[1:]:  # an idle one, then one over the limit
            guards.Connection(_Protocol, guard).connection_made(transport)
        return transports

    answered, idle, newest = asyncio.run(admit_three())
    assert not answered.closed and idle.closed and not newest.closed
