"""Serving the teaching station: :class:`StationServer` runs the app with uvicorn on a socket
bound beforehand (so the printed URL has the real port, and a busy port is a one-line error
before anything moves)."""

from __future__ import annotations

import signal
import socket
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import uvicorn

from ..errors import LfdTrackError

_STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)


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


class StationServer:
    """uvicorn serving one app on a pre-bound socket, in this thread or a background one.

    ``serve()`` blocks until Ctrl-C, SIGTERM or SIGHUP (main thread) or ``shutdown()``;
    ``start()``/``shutdown()`` run it in a background thread (tests, embedding).
    """

    def __init__(self, app: Any, sock: socket.socket) -> None:
        self.sock = sock
        config = uvicorn.Config(
            app,
            log_level="warning",
            access_log=False,
            lifespan="off",
            ws_ping_interval=None,  # the page's heartbeats are the liveness check
            timeout_graceful_shutdown=2,
        )
        self._server = _QuietSignalServer(config)
        self._thread: threading.Thread | None = None

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
    so the session is closed and the summary printed as after any normal end."""

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
