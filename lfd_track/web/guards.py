"""The teaching station's connection guards, below and above uvicorn (see :mod:`.server`).

Below, on asyncio's public API: the server runs on :class:`GuardedLoop`, which puts each
protocol uvicorn's server makes behind a :class:`Connection`. That owns the socket's transport
(admission and the header deadline of :class:`Guard`, the write stall, how a WebSocket's input
is handed on) and gives the protocol a :class:`Pipe`, a transport that goes through it (so a
switch to the WebSocket protocol, ``set_protocol``, is seen too). uvicorn's protocols are driven
through ``asyncio.Protocol``'s methods only. Above, on ASGI: :class:`Tracker` wraps the app and
tells the connection (found by the scope's ``client`` and ``server`` addresses) when a request's
headers came in, when its response went out, when the app took a WebSocket message and when it
closed the WebSocket. This module does not import uvicorn.

The limits are module constants, read when used (tests lower some of them).
"""

from __future__ import annotations

import asyncio
import logging
import struct
import time
from collections.abc import Callable, Mapping, MutableMapping
from typing import Any

HEADER_TIMEOUT_S = 5.0
"""[s] a connection must send its request line and headers within this long (a browser sends
them at once; an idle keep-alive connection is closed after as long)."""
MAX_HEADER_BYTES = 16 * 1024
"""Longest request line and headers (a browser's are under 2 KiB); longer ones get a 400."""
MAX_CONNECTIONS = 128
"""Connections open at once (pages, their WebSockets, status requests): a browser opens up to 6
per page, the app allows 16 pages. Fewer if the process may open few files
(:func:`connection_limit`)."""
WS_MAX_BYTES = 256 * 1024
"""Largest WebSocket message read (the page's are under 100 bytes)."""
WRITE_STALL_S = 10.0
"""[s] a connection whose peer has not read what was sent for this long is dropped."""
READ_SLICE_BYTES = 1024
"""A WebSocket's input is handed to the protocol this much at a time, one slice per turn of the
event loop, and only while fewer than :data:`MAX_QUEUED_MESSAGES` of its messages wait for the
app: a flood of tiny frames read in one go (up to 256 KiB: tens of thousands of frames) would
otherwise hold the event loop for a good part of a second, frames that make no message for the
app (pings, pongs, continuations, which its message budget never sees) as well."""
MAX_QUEUED_MESSAGES = 16
"""Messages handed on ahead of the app per WebSocket (the rest waits, reading paused)."""
MAX_FRAGMENTS = 64
"""Frames one WebSocket message may come in (browsers send the page's in one): empty
continuation frames add nothing to a message's size, only to the server's memory. More are
closed with 1009."""
CLOSE_GRACE_S = 1.0
"""[s] once the server closes a WebSocket it reads nothing more from it (a flooder's backlog is
not parsed to find the close reply) and closes the connection after this long; a connection
still closing (unsent bytes, a peer that reads nothing) one to two times this long after it was
closed is dropped."""
BACKLOG = 32
"""Connections the kernel queues before they are accepted, and asyncio accepts in one go."""
LOG_EVERY_S = 60.0
"""[s] repeated warnings about refused connections are logged at most this often."""

_REFUSAL = (
    b"HTTP/1.1 503 Service Unavailable\r\ncontent-type: text/plain; charset=utf-8\r\n"
    b"connection: close\r\ncontent-length: 29\r\n\r\ntoo many connections: retry\r\n"
)
_Address = tuple[str, int]

_log = logging.getLogger("uvicorn.error")


class Throttled:
    """A warning logged at most once per ``every_s``, with how often it happened meanwhile."""

    def __init__(self, every_s: float = LOG_EVERY_S) -> None:
        self.every_s = every_s
        self._last = -float("inf")
        self._count = 0

    def __call__(self, text: str) -> None:
        self._count += 1
        now = time.monotonic()
        if now - self._last >= self.every_s:
            times = f" ({self._count} times)" if self._count > 1 else ""
            _log.warning("%s%s", text, times)
            self._last, self._count = now, 0


def _address(name: Any) -> _Address | None:
    """``(host, port)`` of a socket address, as an ASGI scope's ``client``/``server`` give it."""
    return (str(name[0]), int(name[1])) if isinstance(name, tuple) and len(name) >= 2 else None


class Guard:
    """The connections of one server: those open, those still owing their request headers."""

    def __init__(self, limit: int, header_timeout_s: float) -> None:
        self.limit = limit
        self.header_timeout_s = header_timeout_s
        self.open: set[asyncio.Transport] = set()
        self.waiting: dict[Connection, None] = {}  # oldest first
        self.by_address: dict[tuple[_Address | None, _Address | None], Connection] = {}
        self.refused = Throttled()
        self.out_of_files = Throttled()
        self._closing: set[asyncio.Transport] = set()

    def admit(self, transport: asyncio.Transport) -> bool:
        """Count a new connection in; False when it must be refused."""
        if len(self.open) >= self.limit:
            if not self.waiting:
                self.refused(f"refusing connections: {self.limit} are open, the most at once")
                return False
            oldest = next(iter(self.waiting))
            oldest.drop()  # a slow (or idle) connection makes room for a new one
        self.open.add(transport)
        return True

    def connection_of(self, scope: Mapping[str, Any]) -> Connection | None:
        """The connection an ASGI request or WebSocket came on (None: not one of this server's)."""
        key = (_address(scope.get("client")), _address(scope.get("server")))
        return self.by_address.get(key)

    def sweep(self, loop: asyncio.AbstractEventLoop) -> None:
        """Drop the connections closing now that were closing at the previous sweep, then sweep
        again in :data:`CLOSE_GRACE_S`: a closed transport lingers until its last bytes are sent,
        which is never when the peer reads nothing (too little waits to stall the writes)."""
        closing = {transport for transport in self.open if transport.is_closing()}
        for transport in closing & self._closing:
            transport.abort()
        self._closing = closing
        loop.call_later(CLOSE_GRACE_S, self.sweep, loop)

    def loop_exception(self, loop: asyncio.AbstractEventLoop, context: dict[str, Any]) -> None:
        """The event loop's exception handler: asyncio logs a traceback for every refused accept
        when the process is out of file descriptors; log that once a minute instead."""
        if context.get("message") == "socket.accept() out of system resource":
            self.out_of_files(f"cannot accept connections: {context.get('exception')}")
            return
        loop.default_exception_handler(context)


class Frames:
    """Follows a client's WebSocket frames (RFC 6455 headers) in the bytes handed on: how many
    messages they completed, and whether a message comes in more than :data:`MAX_FRAGMENTS`."""

    def __init__(self) -> None:
        self.messages = 0
        self._header = bytearray()
        self._left = 0  # payload bytes of the current frame still to come
        self._ends_message = False
        self._fragments = 0  # frames of the message under way

    @staticmethod
    def _header_size(header: bytearray) -> int:
        if len(header) < 2:
            return 2
        length = header[1] & 0x7F
        return 2 + {126: 2, 127: 8}.get(length, 0) + (4 if header[1] & 0x80 else 0)

    def scan(self, data: bytes) -> int | None:
        """Follow ``data``; the offset in it of a frame over the fragment limit, else None."""
        at, end = 0, len(data)
        while at < end:
            if self._left:
                step = min(self._left, end - at)
                at += step
                self._left -= step
                if not self._left:
                    self._frame_done()
                continue
            if not self._header and end - at >= 6 and data[at + 1] & 0x7F < 126:
                # The common case, a whole short header here: read it in place.
                size = 6 if data[at + 1] & 0x80 else 2
                if self._start_frame(data[at], data[at + 1] & 0x7F):
                    return at
                at += size
            else:
                take = self._header_size(self._header) - len(self._header)
                self._header += data[at : at + take]
                at += min(take, end - at)
                if len(self._header) < self._header_size(self._header):
                    continue
                length = self._header[1] & 0x7F
                if length >= 126:
                    length = int.from_bytes(self._header[2 : 4 if length == 126 else 10], "big")
                if self._start_frame(self._header[0], length):
                    return max(0, at - len(self._header))
                self._header.clear()
            if not self._left:
                self._frame_done()
        return None

    def _start_frame(self, first: int, length: int) -> bool:
        """A frame's header is read (its first byte, its payload length): True when the frame
        breaks the fragment limit."""
        fin, opcode = first & 0x80, first & 0x0F
        self._left = length
        self._ends_message = False
        if opcode in (0x1, 0x2):  # text, binary: a new message
            self._fragments = 1
            self._ends_message = bool(fin)
        elif opcode == 0x0:  # continuation
            if self._fragments >= MAX_FRAGMENTS:
                return True
            self._fragments += 1
            self._ends_message = bool(fin)
        return False  # control frames (close, ping, pong) make no message for the app

    def _frame_done(self) -> None:
        if self._ends_message:
            self.messages += 1
            self._ends_message = False


def close_frame(code: int, reason: str) -> bytes:
    """A server's (unmasked) close frame."""
    payload = struct.pack("!H", code) + reason.encode()[:123]
    return bytes([0x88, len(payload)]) + payload


class Connection(asyncio.Protocol):
    """One accepted connection, in front of the protocol uvicorn's server made for it.

    Admission and the header deadline (:class:`Guard`), the write stall, and for a WebSocket
    how its input is handed on: a slice per turn of the event loop, while fewer than
    :data:`MAX_QUEUED_MESSAGES` of its messages wait for the app, at most
    :data:`MAX_FRAGMENTS` frames a message, nothing once the server closed it.
    """

    def __init__(self, make_protocol: Callable[[], Any], guard: Guard) -> None:
        self._make_protocol = make_protocol
        self._guard = guard
        self.transport: asyncio.Transport = None  # type: ignore[assignment]
        self.inner: Any = None  # uvicorn's protocol (HTTP, then WebSocket), once admitted
        self._inner_lost = False
        self._loop = asyncio.get_running_loop()
        self._key: tuple[_Address | None, _Address | None] | None = None
        self._deadline: asyncio.TimerHandle | None = None
        self._stalled: asyncio.TimerHandle | None = None
        self._lost = self._loop.create_future()
        self._head_tail = b""  # the last bytes of a request's head read so far (see data_received)
        # Reading: paused while the protocol asked for it, input waits, or the server closed.
        self._inner_paused = False
        self._reading_paused = False
        self._closing = False
        # WebSocket input (None: still HTTP).
        self._frames: Frames | None = None
        self._unparsed = bytearray()
        self._next_slice: asyncio.Handle | None = None
        self._taken = 0  # messages the app took
        self._app_waiting = False

    # ---------------------------------------------------------------- the transport's side
    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        self.transport = transport  # type: ignore[assignment]
        if not self._guard.admit(self.transport):
            self.transport.write(_REFUSAL)
            self.transport.close()
            return
        sock = transport.get_extra_info("socket")
        try:
            self._key = (_address(sock.getpeername()), _address(sock.getsockname()))
        except (AttributeError, OSError):
            self._key = None  # the peer is gone already: uvicorn's scope names no client either
        if self._key is not None and None not in self._key:
            self._guard.by_address[self._key] = self
        self._await_request()
        self.inner = self._make_protocol()
        self.inner.connection_made(Pipe(self, self.transport))

    def data_received(self, data: bytes) -> None:
        if self.inner is None or self._closing:
            return  # refused, or closed by the server: what the peer still sends is not read
        if self._frames is None:
            if self in self._guard.waiting:
                # A connection whose request head has come in owes nothing more: it is no longer
                # the idle one to make room for a new connection, even before the app has seen it
                # (under load that takes turns of the event loop in which a flood is accepted).
                seen = self._head_tail + data
                if b"\r\n\r\n" in seen:
                    self._stop_waiting()
                self._head_tail = seen[-3:]
            self.inner.data_received(data)
            return
        self._unparsed += data
        self._hand_on()

    def eof_received(self) -> bool | None:
        if self.inner is None or self._inner_lost:
            return None
        return self.inner.eof_received()

    def pause_writing(self) -> None:
        if self._stalled is None:
            self._stalled = self._loop.call_later(WRITE_STALL_S, self.transport.abort)
        if self.inner is not None and not self._inner_lost:
            self.inner.pause_writing()

    def resume_writing(self) -> None:
        self._clear_stall()
        if self.inner is not None and not self._inner_lost:
            self.inner.resume_writing()

    def connection_lost(self, exc: Exception | None) -> None:
        self._stop_waiting()
        self._clear_stall()
        if self._next_slice is not None:
            self._next_slice.cancel()
            self._next_slice = None
        self._guard.open.discard(self.transport)
        if self._key is not None and self._guard.by_address.get(self._key) is self:
            del self._guard.by_address[self._key]
        self._lose_inner(exc)
        if not self._lost.done():
            self._lost.set_result(None)

    # ---------------------------------------------------------------- the protocol's side
    def switch_to(self, protocol: Any) -> None:
        """The protocol handed the connection on (an HTTP upgrade to a WebSocket)."""
        self.inner = protocol
        self._frames = Frames()

    def inner_pause(self, paused: bool) -> None:
        """The protocol paused or resumed reading."""
        self._inner_paused = paused
        self._update_reading()
        if not paused and self._unparsed:
            self._hand_on()

    def inner_close(self) -> None:
        """The protocol closed the transport (kept open until the grace ends when closing)."""
        if not self._closing:
            self.transport.close()

    def is_closing(self) -> bool:
        return self._closing or self.transport.is_closing()

    # ---------------------------------------------------------------- the app's side (ASGI)
    def request_started(self) -> None:
        """A request's line and headers (or a WebSocket's handshake) came in: in time."""
        self._stop_waiting()

    def response_done(self) -> None:
        """The response went out: the next request's headers are due in time."""
        if not self.transport.is_closing():
            self._await_request()

    def app_receiving(self) -> None:
        """The app waits for a WebSocket message: hand on what waits even at the queue limit."""
        self._app_waiting = True
        if self._unparsed and self._next_slice is None:
            self._next_slice = self._loop.call_soon(self._hand_on_next)

    def app_received(self, message: Mapping[str, Any]) -> None:
        self._app_waiting = False
        if message.get("type") == "websocket.receive":
            self._taken += 1
        if self._unparsed and self._next_slice is None:
            self._next_slice = self._loop.call_soon(self._hand_on_next)

    def server_closed(self) -> None:
        """The app closed the WebSocket (its close frame is sent): read nothing more, let it
        go out, then close (closing at once, with the peer's input unread, would reset the
        connection before the peer read why)."""
        if self.transport.is_closing():
            return
        self._closing = True
        self._unparsed.clear()
        self._update_reading()
        self._loop.call_later(CLOSE_GRACE_S, self.transport.close)

    async def gone(self) -> None:
        """Wait until the connection is closed."""
        await asyncio.shield(self._lost)

    # ---------------------------------------------------------------- guards
    def drop(self) -> None:
        """Close now: no request (headers) in time, or room is needed for a new connection."""
        self._stop_waiting()
        self._guard.open.discard(self.transport)
        if self.transport.get_write_buffer_size():
            self.transport.abort()  # the peer reads nothing either: free the socket now
        else:
            self.transport.close()

    def _await_request(self) -> None:
        self._stop_waiting()
        self._head_tail = b""
        self._deadline = self._loop.call_later(self._guard.header_timeout_s, self.drop)
        self._guard.waiting[self] = None

    def _stop_waiting(self) -> None:
        if self._deadline is not None:
            self._deadline.cancel()
            self._deadline = None
        self._guard.waiting.pop(self, None)

    def _clear_stall(self) -> None:
        if self._stalled is not None:
            self._stalled.cancel()
            self._stalled = None

    def _lose_inner(self, exc: Exception | None) -> None:
        if self.inner is not None and not self._inner_lost:
            self._inner_lost = True
            self.inner.connection_lost(exc)

    def _update_reading(self) -> None:
        paused = self._inner_paused or bool(self._unparsed) or self._closing
        if paused != self._reading_paused and not self.transport.is_closing():
            self._reading_paused = paused
            if paused:
                self.transport.pause_reading()
            else:
                self.transport.resume_reading()

    def _may_hand_on(self) -> bool:
        assert self._frames is not None
        queued = self._frames.messages - self._taken
        return queued < MAX_QUEUED_MESSAGES or self._app_waiting

    def _hand_on(self) -> None:
        """Hand the protocol one slice of the WebSocket's input; the next waits for the next
        turn of the event loop (reading paused meanwhile), or for the app to take messages."""
        if self._closing or self.transport.is_closing() or self._frames is None:
            return
        if self._unparsed and self._may_hand_on():
            piece = bytes(self._unparsed[:READ_SLICE_BYTES])
            del self._unparsed[:READ_SLICE_BYTES]
            over = self._frames.scan(piece)
            if over is not None:
                if over:
                    self.inner.data_received(piece[:over])
                self._fail(1009, f"a message in more than {MAX_FRAGMENTS} frames")
                return
            self.inner.data_received(piece)
            if self._closing or self.transport.is_closing():
                return
        self._update_reading()
        if self._unparsed and self._next_slice is None and self._may_hand_on():
            self._next_slice = self._loop.call_soon(self._hand_on_next)

    def _hand_on_next(self) -> None:
        self._next_slice = None
        try:
            self._hand_on()
        except Exception:
            self.transport.abort()  # as asyncio does when data_received fails
            raise

    def _fail(self, code: int, reason: str) -> None:
        """Close the WebSocket with ``code`` (the app sees it gone at once)."""
        if not self.transport.is_closing():
            self.transport.write(close_frame(code, reason))
        self.server_closed()
        self._lose_inner(None)


class Pipe(asyncio.Transport):
    """The transport uvicorn's protocol writes to and reads through: the socket's, by way of
    its :class:`Connection` (which sees a switch of protocol, and keeps reading paused while
    input waits or the server closed)."""

    def __init__(self, connection: Connection, transport: asyncio.Transport) -> None:
        super().__init__()
        self._connection = connection
        self._transport = transport

    def get_extra_info(self, name: str, default: Any = None) -> Any:
        return self._transport.get_extra_info(name, default)

    def is_closing(self) -> bool:
        return self._connection.is_closing()

    def close(self) -> None:
        self._connection.inner_close()

    def abort(self) -> None:
        self._transport.abort()

    def set_protocol(self, protocol: asyncio.BaseProtocol) -> None:
        self._connection.switch_to(protocol)

    def get_protocol(self) -> asyncio.BaseProtocol:
        return self._connection.inner

    def is_reading(self) -> bool:
        return not self._connection._inner_paused

    def pause_reading(self) -> None:
        self._connection.inner_pause(True)

    def resume_reading(self) -> None:
        self._connection.inner_pause(False)

    def write(self, data: bytes | bytearray | memoryview) -> None:
        if not self._connection._closing:
            self._transport.write(data)

    def writelines(self, list_of_data: Any) -> None:
        for data in list_of_data:
            self.write(data)

    def write_eof(self) -> None:
        self._transport.write_eof()

    def can_write_eof(self) -> bool:
        return self._transport.can_write_eof()

    def get_write_buffer_size(self) -> int:
        return self._transport.get_write_buffer_size()

    def get_write_buffer_limits(self) -> tuple[int, int]:
        return self._transport.get_write_buffer_limits()

    def set_write_buffer_limits(self, high: int | None = None, low: int | None = None) -> None:
        self._transport.set_write_buffer_limits(high, low)


class GuardedLoop(asyncio.SelectorEventLoop):
    """asyncio's selector loop, whose servers put each new protocol behind a
    :class:`Connection` of ``guard``."""

    def __init__(self, guard: Guard) -> None:
        super().__init__()
        self._guard = guard

    async def create_server(
        self, protocol_factory: Callable[[], Any], *args: Any, **kwargs: Any
    ) -> asyncio.Server:
        guard = self._guard
        return await super().create_server(
            lambda: Connection(protocol_factory, guard), *args, **kwargs
        )


_Message = MutableMapping[str, Any]


class Tracker:
    """ASGI middleware that tells each request's :class:`Connection` what the app does."""

    def __init__(self, app: Any, guard: Guard) -> None:
        self.app = app
        self.guard = guard

    async def __call__(self, scope: Any, receive: Any, send: Any) -> None:
        kind = scope.get("type")
        connection = self.guard.connection_of(scope) if kind in ("http", "websocket") else None
        if connection is None:
            await self.app(scope, receive, send)
            return
        connection.request_started()
        if kind == "http":
            await self._http(connection, scope, receive, send)
        else:
            await self._websocket(connection, scope, receive, send)

    async def _http(self, connection: Connection, scope: Any, receive: Any, send: Any) -> None:
        done = False

        async def tracked_send(message: _Message) -> None:
            nonlocal done
            await send(message)
            if message["type"] == "http.response.body" and not message.get("more_body"):
                done = True
                connection.response_done()

        try:
            await self.app(scope, receive, tracked_send)
        finally:
            if not done:
                connection.response_done()  # uvicorn answered (500) for the app

    async def _websocket(self, connection: Connection, scope: Any, receive: Any, send: Any) -> None:
        refused = False

        async def tracked_receive() -> _Message:
            connection.app_receiving()
            message: _Message = {}
            try:
                message = await receive()
            finally:
                connection.app_received(message)
            return message

        async def tracked_send(message: _Message) -> None:
            nonlocal refused
            await send(message)
            if message["type"] == "websocket.close":
                connection.server_closed()
            elif message["type"] == "websocket.http.response.body":
                refused = refused or not message.get("more_body")

        await self.app(scope, tracked_receive, tracked_send)
        if refused:
            await connection.gone()  # see the module's docstring (uvicorn before 0.55)
