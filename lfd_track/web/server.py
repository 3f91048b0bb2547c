"""Serving the teaching station: :class:`StationServer` runs the app with uvicorn on a socket
bound beforehand (so the printed URL has the real port, and a busy port is a one-line error
before anything moves).

Connections are guarded (:class:`_Guard`): each must send a complete request line and headers
within :data:`HEADER_TIMEOUT_S` of connecting or of its previous response, or it is closed (a
slow-loris client cannot hold sockets); at most :data:`MAX_CONNECTIONS` are open at once (fewer
if the process may open few files): a new one takes the place of the oldest that has not sent
its headers yet, or is answered 503 and closed. A connection whose peer stops reading for
:data:`WRITE_STALL_S` is dropped, and so is one still closing :data:`CLOSE_GRACE_S` after the
server closed it (its last bytes cannot go out). Running out of file descriptors anyway is
logged once a minute, not once per refused accept.
"""

from __future__ import annotations

import asyncio
import functools
import logging
import signal
import socket
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

from ..errors import LfdTrackError
from ..utils.extras import needs_extra

with needs_extra("web"):
    # The only module that knows uvicorn: it extends these two protocol classes, whose
    # internals tests/web/test_uvicorn_internals.py checks against the installed uvicorn.
    import uvicorn
    from uvicorn.protocols.http.h11_impl import H11Protocol
    from uvicorn.protocols.websockets.websockets_sansio_impl import WebSocketsSansIOProtocol

_STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)

HEADER_TIMEOUT_S = 5.0
"""[s] a connection must send its request line and headers within this long (a browser sends
them at once; an idle keep-alive connection is closed after as long)."""
MAX_CONNECTIONS = 128
"""Connections open at once (pages, their WebSockets, status requests): a browser opens up to 6
per page, the app allows 16 pages. Fewer if the process may open few files
(:func:`connection_limit`)."""
WS_MAX_BYTES = 256 * 1024
"""Largest WebSocket message read (the page's are under 100 bytes)."""
WRITE_STALL_S = 10.0
"""[s] a connection whose peer has not read what was sent for this long is dropped."""
READ_SLICE_BYTES = 1024
"""A WebSocket's input is parsed this much at a time, one slice per turn of the event loop, and
only while fewer than :data:`MAX_QUEUED_MESSAGES` messages wait for the app: a flood of tiny
frames read in one go (up to 256 KiB: tens of thousands of frames) would otherwise hold the
event loop for a good part of a second, frames that make no message for the app (pings, pongs,
continuations, which its message budget never sees) as well."""
MAX_QUEUED_MESSAGES = 16
"""Messages parsed ahead of the app per WebSocket (the rest waits unparsed, reading paused)."""
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
_RESERVED_FILES = 32
"""File descriptors kept for the station's own use (recording, camera, serial link, ...)."""
LOG_EVERY_S = 60.0
"""[s] repeated warnings about refused connections are logged at most this often."""

_log = logging.getLogger("uvicorn.error")


def bind_socket(host: str, port: int) -> socket.socket:
    """A listening TCP socket on ``host``:``port`` (0 picks a free port); one-line errors."""
    try:
        infos = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM, flags=socket.AI_PASSIVE)
    except socket.gaierror as exc:
        raise LfdTrackError(f"--host {host}: cannot resolve ({exc.strerror})") from None
    family, kind, proto, _, address = infos[0]
    sock = socket.socket(family, kind, proto)
    try:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.bind(address)
        sock.listen(16)
    except OSError as exc:
        sock.close()
        raise LfdTrackError(f"cannot listen on {host}:{port}: {exc.strerror or exc}") from None
    sock.set_inheritable(True)
    return sock


def station_url(host: str, port: int, token: str | None) -> str:
    """The URL to open: ``http://HOST:PORT/`` plus ``?token=…`` when one is required."""
    shown = socket.gethostname() if host in ("0.0.0.0", "::", "") else host
    if ":" in shown:
        shown = f"[{shown}]"
    return f"http://{shown}:{port}/" + (f"?token={token}" if token else "")


def connection_limit(wanted: int = MAX_CONNECTIONS) -> int:
    """``wanted``, or fewer if the process may open few files: room is left for the station's
    own files and for five rounds of accepts (a connection over the limit holds its descriptor
    for three or four turns of the event loop, until it is refused and closed). At least 8."""
    try:
        import resource

        soft, _ = resource.getrlimit(resource.RLIMIT_NOFILE)
    except (ImportError, OSError, ValueError):
        return wanted
    if soft == resource.RLIM_INFINITY or soft <= 0:
        return wanted
    return max(8, min(wanted, soft - 5 * BACKLOG - _RESERVED_FILES))


class _Throttled:
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


class _Guard:
    """The connections of one server: those open, those still owing their request headers."""

    def __init__(self, limit: int, header_timeout_s: float) -> None:
        self.limit = limit
        self.header_timeout_s = header_timeout_s
        self.open: set[asyncio.BaseTransport] = set()
        self.waiting: dict[_GuardedHttp, None] = {}  # oldest first
        self.refused = _Throttled()
        self.out_of_files = _Throttled()
        self._closing: set[asyncio.BaseTransport] = set()

    def admit(self, transport: asyncio.BaseTransport) -> bool:
        """Count a new connection in; False when it must be refused."""
        if len(self.open) >= self.limit:
            if not self.waiting:
                self.refused(f"refusing connections: {self.limit} are open, the most at once")
                return False
            oldest = next(iter(self.waiting))
            oldest.drop()  # a slow (or idle) connection makes room for a new one
        self.open.add(transport)
        return True

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


class _WriteStall:
    """Drops a connection whose peer has read nothing for :data:`WRITE_STALL_S` (uvicorn waits
    for it for good); mixed into a uvicorn protocol, before it."""

    _stalled: asyncio.TimerHandle | None = None
    loop: asyncio.AbstractEventLoop
    transport: asyncio.Transport

    def pause_writing(self) -> None:
        super().pause_writing()  # type: ignore[misc]
        if self._stalled is None:
            self._stalled = self.loop.call_later(WRITE_STALL_S, self.transport.abort)

    def resume_writing(self) -> None:
        super().resume_writing()  # type: ignore[misc]
        self._clear_stall()

    def connection_lost(self, exc: Exception | None) -> None:
        self._clear_stall()
        super().connection_lost(exc)  # type: ignore[misc]

    def _clear_stall(self) -> None:
        if self._stalled is not None:
            self._stalled.cancel()
            self._stalled = None


class _GuardedHttp(_WriteStall, H11Protocol):
    """uvicorn's HTTP/1.1 protocol with the :class:`_Guard`'s limits; a response the peer does
    not read is dropped after :data:`WRITE_STALL_S` (see :class:`_WriteStall`)."""

    def __init__(self, *args: Any, guard: _Guard, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._guard = guard
        self._deadline: asyncio.TimerHandle | None = None
        self._awaited: Any = None  # the scope of the last request when the deadline was set

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        super().connection_made(transport)  # type: ignore[arg-type]
        if not self._guard.admit(transport):
            self.transport.write(
                b"HTTP/1.1 503 Service Unavailable\r\ncontent-type: text/plain; charset=utf-8"
                b"\r\nconnection: close\r\ncontent-length: 29\r\n\r\ntoo many connections: retry\r\n"
            )
            self.transport.close()
            return
        self._await_request()

    def data_received(self, data: bytes) -> None:
        super().data_received(data)
        self._check_request()

    def on_response_complete(self) -> None:
        if not self.transport.is_closing():
            self._await_request()
        super().on_response_complete()  # may go on to a pipelined request
        self._check_request()

    def connection_lost(self, exc: Exception | None) -> None:
        self._stop_waiting()
        self._guard.open.discard(self.transport)
        super().connection_lost(exc)

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
        self._awaited = self.scope
        self._deadline = self.loop.call_later(self._guard.header_timeout_s, self.drop)
        self._guard.waiting[self] = None

    def _check_request(self) -> None:
        """A new request's line and headers have come (uvicorn made its scope): in time."""
        if self._deadline is not None and self.scope is not self._awaited:
            self._stop_waiting()

    def _stop_waiting(self) -> None:
        if self._deadline is not None:
            self._deadline.cancel()
            self._deadline = None
        self._guard.waiting.pop(self, None)


class _GuardedWebSocket(_WriteStall, WebSocketsSansIOProtocol):
    """uvicorn's WebSocket protocol, counted by the :class:`_Guard`, and fair to the others:
    input is parsed a slice per turn of the event loop, only as fast as the app takes the
    messages (see :data:`READ_SLICE_BYTES`), a message in at most :data:`MAX_FRAGMENTS` frames;
    nothing is read once the server closes (:data:`CLOSE_GRACE_S`); a peer that reads nothing
    for :data:`WRITE_STALL_S` is dropped (its socket would otherwise be held for good)."""

    def __init__(self, *args: Any, guard: _Guard, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._guard = guard
        self._unparsed = bytearray()
        self._next_slice: asyncio.Handle | None = None

    def data_received(self, data: bytes) -> None:
        if self.close_sent:
            return  # closing (see send): what the peer still sends is not read
        self._unparsed += data
        self._parse()

    def _parse(self) -> None:
        """Parse one slice; the next waits for the next turn of the event loop (reading paused
        meanwhile), or for the app to take messages when :data:`MAX_QUEUED_MESSAGES` wait."""
        if self.close_sent or self.transport.is_closing():
            return
        if self._unparsed and self.queue.qsize() < MAX_QUEUED_MESSAGES:
            piece = bytes(self._unparsed[:READ_SLICE_BYTES])
            del self._unparsed[:READ_SLICE_BYTES]
            super().data_received(piece)
            if self.close_sent or self.transport.is_closing():
                return
        if not self._unparsed:
            if self.read_paused and self.queue.empty():  # as uvicorn's receive would
                self.read_paused = False
                self.transport.resume_reading()
            return
        if not self.read_paused:
            self.read_paused = True
            self.transport.pause_reading()
        if self._next_slice is None and self.queue.qsize() < MAX_QUEUED_MESSAGES:
            self._next_slice = self.loop.call_soon(self._parse_next)

    def _parse_next(self) -> None:
        self._next_slice = None
        try:
            self._parse()
        except Exception:
            self.transport.abort()  # as asyncio does when data_received fails
            raise

    def handle_cont(self, event: Any) -> None:
        if self.close_sent:
            return
        if len(self.frames) >= MAX_FRAGMENTS:
            reason = f"a message in more than {MAX_FRAGMENTS} frames"
            self.frames = []
            self.conn.fail(1009, reason)  # the close frame (as uvicorn's keepalive_timeout)
            self.transport.write(b"".join(self.conn.data_to_send()))
            self.queue.put_nowait({"type": "websocket.disconnect", "code": 1009, "reason": reason})
            self._close_after_grace()
            return
        super().handle_cont(event)

    async def receive(self) -> Any:
        message = await super().receive()  # resumes reading once the queue is empty
        if self._unparsed:
            self._parse()  # the rest first (pauses reading again if some is left)
        return message

    async def send(self, message: Any) -> None:
        await super().send(message)
        if message["type"] == "websocket.http.response.body" and not message.get("more_body"):
            # A refusal (HTTP 503, 400) ends the handshake too: without this uvicorn logs an
            # error for every refused WebSocket.
            self.handshake_complete = True
        elif message["type"] == "websocket.close" and self.close_timer is not None:
            # uvicorn reads on for the peer's close reply (10 s at most): from a flooder that
            # is all its backlog first.
            self._close_after_grace()

    def _close_after_grace(self) -> None:
        """The close frame is sent: read nothing more, let it go out, then close (closing at
        once, with the peer's input unread, would reset the connection before the peer read
        why)."""
        self.close_sent = True
        self._unparsed.clear()
        if not self.read_paused:
            self.read_paused = True
            self.transport.pause_reading()
        if self.close_timer is not None:
            self.close_timer.cancel()
        self.close_timer = self.loop.call_later(CLOSE_GRACE_S, self.transport.close)

    def connection_lost(self, exc: Exception | None) -> None:
        self._guard.open.discard(self.transport)
        super().connection_lost(exc)


class StationServer:
    """uvicorn serving one app on a pre-bound socket, in this thread or a background one.

    ``serve()`` blocks until Ctrl-C, SIGTERM or SIGHUP (main thread) or ``shutdown()``;
    ``start()``/``shutdown()`` run it in a background thread (tests, embedding).
    ``header_timeout_s`` and ``max_connections``: see :data:`HEADER_TIMEOUT_S` and
    :data:`MAX_CONNECTIONS` (the latter is capped by :func:`connection_limit`).
    """

    def __init__(
        self,
        app: Any,
        sock: socket.socket,
        *,
        header_timeout_s: float = HEADER_TIMEOUT_S,
        max_connections: int = MAX_CONNECTIONS,
    ) -> None:
        if not header_timeout_s > 0:
            raise ValueError(f"header_timeout_s must be positive, got {header_timeout_s}")
        self.sock = sock
        self._guard = _Guard(connection_limit(max_connections), header_timeout_s)
        config = uvicorn.Config(
            app,
            log_level="warning",
            access_log=False,
            lifespan="off",
            loop="asyncio",  # what this module relies on (uvicorn's "auto" may pick uvloop)
            http=functools.partial(_GuardedHttp, guard=self._guard),  # type: ignore[arg-type]
            ws=functools.partial(_GuardedWebSocket, guard=self._guard),  # type: ignore[arg-type]
            ws_max_size=WS_MAX_BYTES,
            ws_per_message_deflate=False,  # the frames are JPEGs: nothing to gain
            ws_ping_interval=None,  # the page's heartbeats are the liveness check
            timeout_keep_alive=int(HEADER_TIMEOUT_S),
            timeout_graceful_shutdown=2,
            backlog=BACKLOG,
        )
        self._server = _QuietSignalServer(config, self._guard)
        self._thread: threading.Thread | None = None

    @property
    def max_connections(self) -> int:
        """Connections served at once (see :func:`connection_limit`)."""
        return self._guard.limit

    @property
    def port(self) -> int:
        """The port actually listened on."""
        return int(self.sock.getsockname()[1])

    def serve(self) -> None:
        """Serve until asked to stop (returns normally on Ctrl-C)."""
        self._server.run(sockets=[self.sock])

    def start(self) -> StationServer:
        """Serve from a background thread; returns once the server accepts connections."""
        self._thread = threading.Thread(target=self.serve, name="lfd-track teach", daemon=True)
        self._thread.start()
        while not self._server.started:
            if not self._thread.is_alive():
                raise RuntimeError("the teaching station's server failed to start")
            self._thread.join(0.01)
        return self

    def shutdown(self) -> None:
        """Stop serving and wait for the server to finish."""
        self._server.should_exit = True
        if self._thread is not None:
            self._thread.join(timeout=10.0)
        self.sock.close()


class _QuietSignalServer(uvicorn.Server):
    """uvicorn's server, but Ctrl-C/SIGTERM/SIGHUP only end ``serve`` (no re-raise afterwards),
    so the session is closed and the summary printed as after any normal end; running out of
    file descriptors is logged once a minute."""

    def __init__(self, config: uvicorn.Config, guard: _Guard) -> None:
        super().__init__(config)
        self._guard = guard

    async def startup(self, sockets: list[socket.socket] | None = None) -> None:
        loop = asyncio.get_running_loop()
        loop.set_exception_handler(self._guard.loop_exception)
        await super().startup(sockets=sockets)
        self._guard.sweep(loop)

    @contextmanager
    def capture_signals(self) -> Iterator[None]:
        if threading.current_thread() is not threading.main_thread():
            yield
            return
        previous = {sig: signal.signal(sig, self.handle_exit) for sig in _STOP_SIGNALS}
        try:
            yield
        finally:
            for sig, handler in previous.items():
                signal.signal(sig, handler)
