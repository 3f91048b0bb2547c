"""Serving the teaching station: :class:`StationServer` runs the app with uvicorn on a socket
bound beforehand (so the printed URL has the real port, and a busy port is a one-line error
before anything moves).

Connections are guarded (:mod:`.guards`): each must send a complete request line and headers
within :data:`~.guards.HEADER_TIMEOUT_S` of connecting or of its previous response, or it is
closed (a slow-loris client cannot hold sockets); at most :data:`~.guards.MAX_CONNECTIONS` are
open at once (fewer if the process may open few files): a new one takes the place of the oldest
that has not sent its headers yet, or is answered 503 and closed. A connection whose peer stops
reading for :data:`~.guards.WRITE_STALL_S` is dropped, and so is one still closing
:data:`~.guards.CLOSE_GRACE_S` after the server closed it (its last bytes cannot go out). A
WebSocket's input is handed on a slice per turn of the event loop and only as fast as the app
takes its messages (:data:`~.guards.READ_SLICE_BYTES`), a message in at most
:data:`~.guards.MAX_FRAGMENTS` frames. Running out of file descriptors is logged once a minute,
not once per refused accept.

Only uvicorn's public API is used: ``uvicorn.Config`` (its documented options) and
``uvicorn.Server`` (``serve``, ``started``, ``should_exit``), on an event loop of this package's
making; uvicorn's protocols are driven as the asyncio protocols they are, never subclassed or
looked into (``tests/web/test_uvicorn_public_api.py`` checks this), so the requirement has no
upper bound.

One behaviour of uvicorn is worked around, not relied on: before 0.55 its WebSocket protocol
logged an error for every WebSocket refused with an HTTP response (503, 400) when the app
returned at once; :class:`~.guards.Tracker` lets the app return only once such a connection is
gone.
"""

from __future__ import annotations

import asyncio
import logging
import signal
import socket
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

from ..errors import LfdTrackError
from ..utils.extras import needs_extra
from .guards import (
    BACKLOG,
    HEADER_TIMEOUT_S,
    MAX_CONNECTIONS,
    MAX_HEADER_BYTES,
    WS_MAX_BYTES,
    Guard,
    GuardedLoop,
    Tracker,
)

with needs_extra("web"):
    import uvicorn  # the only module that knows uvicorn: Config and Server, nothing else
    import websockets  # noqa: F401  uvicorn imports it only when a page connects (ws="websockets-sansio")

_log = logging.getLogger("uvicorn.error")

__all__ = ["StationServer", "bind_socket", "connection_limit", "station_url"]

_STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
_RESERVED_FILES = 32
"""File descriptors kept for the station's own use (recording, camera, serial link, ...)."""


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
        self._guard = Guard(connection_limit(max_connections), header_timeout_s)
        config = uvicorn.Config(
            Tracker(app, self._guard),
            log_level="warning",
            access_log=False,
            lifespan="off",
            loop="asyncio",  # the server runs on GuardedLoop, asyncio's selector loop
            http="h11",
            ws="websockets-sansio",
            ws_max_size=WS_MAX_BYTES,
            ws_per_message_deflate=False,  # the frames are JPEGs: nothing to gain
            ws_ping_interval=None,  # the page's heartbeats are the liveness check
            h11_max_incomplete_event_size=MAX_HEADER_BYTES,
            timeout_keep_alive=int(HEADER_TIMEOUT_S),
            timeout_graceful_shutdown=2,
            backlog=BACKLOG,
        )
        self._server = uvicorn.Server(config)
        self._thread: threading.Thread | None = None

    @property
    def max_connections(self) -> int:
        """Connections served at once (see :func:`connection_limit`)."""
        return self._guard.limit

    @property
    def port(self) -> int:
        """The port actually listened on."""
        return int(self.sock.getsockname()[1])

    def new_loop(self) -> asyncio.AbstractEventLoop:
        """The event loop the server runs on: asyncio's selector loop with the guards (this
        module relies on its accept-error message, its reads and its transports' flow control;
        uvicorn's "auto" would pick uvloop wherever it is installed)."""
        return GuardedLoop(self._guard)

    def serve(self) -> None:
        """Serve until asked to stop (returns normally on Ctrl-C, SIGTERM or SIGHUP)."""
        with self._stop_signals(), asyncio.Runner(loop_factory=self.new_loop) as runner:
            runner.run(self._serve())

    async def _serve(self) -> None:
        loop = asyncio.get_running_loop()
        loop.set_exception_handler(self._guard.loop_exception)
        self._guard.sweep(loop)
        await self._server.serve(sockets=[self.sock])

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

    @contextmanager
    def _stop_signals(self) -> Iterator[None]:
        """In the main thread, Ctrl-C, SIGTERM and SIGHUP only end ``serve`` (the session is then
        closed and the summary printed as after any normal end). uvicorn takes SIGINT and SIGTERM
        over while it serves and raises them again once it stopped; they then come here."""
        if threading.current_thread() is not threading.main_thread():
            yield
            return

        def stop(signum: int, frame: Any) -> None:
            self._server.should_exit = True

        previous = {sig: signal.signal(sig, stop) for sig in _STOP_SIGNALS}
        try:
            yield
        finally:
            for sig, handler in previous.items():
                signal.signal(sig, handler)
