"""The teaching station's ASGI app (Starlette): the page, the status API and the WebSocket.

Routes (every one behind :class:`AccessGuard`):

- ``GET /`` — the page (``static/index.html`` with the token filled in);
- ``GET /static/<file>`` — its script and style sheet, shipped in the package;
- ``GET /api/status`` — the session's status as JSON (see :data:`.contract.STATUS_FIELDS`);
- ``WS /ws`` — commands and heartbeats in, frames and status out.

WebSocket protocol (defined once in :mod:`.contract`, which the page reads too): the page sends
JSON text messages ``{"type": ...}`` of the :class:`~.contract.ClientMessage` types; the server
sends binary messages, a :class:`~.contract.ViewTag` byte and a JPEG (the camera view at ``fps``,
the simulator's top-down view when it changed), and JSON text messages of the
:class:`~.contract.ServerMessage` types (``status``, with the page's ``role``, and ``error``).
The page gets :func:`~.contract.page_contract` inline (a JSON data block filled in by ``GET /``),
so its script holds no second copy of the types. Only the controlling page's commands move the
robot; the others watch.

Hostile pages. Every page shares the one event loop, so each message is answered and then the
loop is handed on (no page can hold it); a page may send :data:`MESSAGE_BURST` messages at once
and :data:`MESSAGE_RATE` a second after that, or it is closed with code 1008 (the page itself
sends a heartbeat every :data:`~.contract.HEARTBEAT_S` and a press and release per button); at most :data:`MAX_PAGES`
pages are open at once (more are refused with HTTP 503). A ``stop`` runs in a thread of its own
(:class:`StopLine`), never behind other pages' work, and the loop waits for it briefly so a
flooded loop cannot starve it of the interpreter. Messages longer than
:data:`MAX_MESSAGE_CHARS`, nested too deeply, binary or not JSON objects get an error reply.
"""

from __future__ import annotations

import asyncio
import html
import ipaddress
import itertools
import json
import secrets
import threading
import time
from collections.abc import Callable, Mapping
from concurrent.futures import Future, ThreadPoolExecutor, wait
from dataclasses import dataclass
from importlib import resources
from typing import Any
from urllib.parse import parse_qs, urlsplit

from ..utils.extras import needs_extra
from .contract import (
    COMMAND_NAMES,
    ClientMessage,
    ServerMessage,
    TeachingSession,
    ViewTag,
    page_contract,
)
from .defaults import DEFAULT_FPS

with needs_extra("web"):
    from starlette.applications import Starlette
    from starlette.requests import Request
    from starlette.responses import HTMLResponse, JSONResponse, PlainTextResponse, Response
    from starlette.routing import Route, WebSocketRoute
    from starlette.types import ASGIApp, Receive, Scope, Send
    from starlette.websockets import WebSocket, WebSocketDisconnect

STATIC_FILES = {
    "app.js": "text/javascript; charset=utf-8",
    "style.css": "text/css; charset=utf-8",
}
MAX_PAGES = 16
"""Pages (WebSockets) open at once; more are refused with HTTP 503. A station has a laptop, a
phone and a few watchers; each page gets the live view at ``fps``."""
MESSAGE_RATE = 100.0
"""[messages/s] a page may send in the long run. The page sends 4 heartbeats a second plus a
press and a release per button push or key stroke (a frantic person: ~10 a second): ~24/s at
most, a quarter of this."""
MESSAGE_BURST = 300
"""Messages a page may send at once before :data:`MESSAGE_RATE` applies (a phone whose link
stalled for a while delivers what it queued in one go)."""
MAX_MESSAGE_CHARS = 8192
"""Longest message read (the page's are under 100 characters); longer ones get an error."""
_SHOWN_CHARS = 40
"""A bad value is quoted in an error reply up to this many characters."""

_SECURITY_HEADERS = {
    # Everything the page needs comes from this server; nothing is fetched from elsewhere.
    "Content-Security-Policy": (
        "default-src 'none'; script-src 'self'; style-src 'self'; img-src 'self' blob:; "
        "connect-src 'self'; base-uri 'none'; form-action 'none'; frame-ancestors 'none'"
    ),
    "Referrer-Policy": "no-referrer",
    "Cache-Control": "no-store",
    "X-Content-Type-Options": "nosniff",
}


def is_loopback(host: str) -> bool:
    """True for ``localhost`` and loopback addresses (127.0.0.0/8, ::1)."""
    name = host.strip("[]").lower()
    if name == "localhost":
        return True
    try:
        return ipaddress.ip_address(name).is_loopback
    except ValueError:
        return False


def new_token() -> str:
    """A fresh random access token (URL-safe, 128 bits)."""
    return secrets.token_urlsafe(16)


def _host_name(host_header: str) -> str | None:
    """The host part of a ``Host`` header value (``[::1]:8765`` → ``::1``); None when the value
    is malformed (``[::1`` without its bracket)."""
    try:
        return urlsplit(f"//{host_header}").hostname or ""
    except ValueError:
        return None


def _origin_netloc(origin: str) -> str | None:
    """``host[:port]`` of an ``Origin`` header value, None when it is malformed."""
    try:
        return urlsplit(origin).netloc.lower()
    except ValueError:
        return None


def _short(value: Any) -> str:
    """``repr(value)``, cut to :data:`_SHOWN_CHARS` characters for an error reply."""
    text = repr(value)
    return text if len(text) <= _SHOWN_CHARS else text[:_SHOWN_CHARS] + "…"


class AccessGuard:
    """ASGI middleware: token, ``Host`` and ``Origin`` checks on every request and WebSocket.

    - With a ``token``, every request must carry ``?token=<token>``; otherwise 403.
    - Without one (loopback only), the ``Host`` header must name a loopback host, so a web page
      elsewhere cannot reach the robot through DNS rebinding.
    - A WebSocket whose ``Origin`` is another site than the ``Host`` it connects to is refused:
      any page open in the same browser could otherwise drive the robot.

    A refused WebSocket is closed before it is accepted, which the server answers with HTTP 403.
    A malformed ``Host`` header is answered with 400, a malformed ``Origin`` is refused.
    """

    def __init__(self, app: ASGIApp, token: str | None) -> None:
        self.app = app
        self.token = token

    def _problem(self, scope: Scope) -> tuple[int, str] | None:
        """``(HTTP status, reason)`` when the request is refused, else None."""
        headers = {k.decode("latin-1"): v.decode("latin-1") for k, v in scope["headers"]}
        host = headers.get("host", "")
        host_name = _host_name(host)
        if host_name is None:
            return 400, "malformed Host header"
        if self.token is None:
            if not is_loopback(host_name):
                return 403, "this station serves loopback only"
        else:
            given = parse_qs(scope.get("query_string", b"").decode("latin-1")).get("token", [""])
            if not secrets.compare_digest(given[-1].encode(), self.token.encode()):
                return 403, "missing or wrong token: open the URL the teach command printed"
        if scope["type"] == "websocket":
            origin = headers.get("origin")
            if origin is not None and _origin_netloc(origin) != host.lower():
                return 403, "cross-site WebSocket refused"
        return None

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        problem = self._problem(scope)
        if problem is None:
            await self.app(scope, receive, send)
            return
        code, reason = problem
        response = PlainTextResponse(f"{code} {_REASONS[code]}: {reason}\n", status_code=code)
        if scope["type"] == "http":
            await response(scope, receive, send)
        elif code == 403:
            await send({"type": "websocket.close", "code": 1008, "reason": reason})
        else:
            await WebSocket(scope, receive, send).send_denial_response(response)


_REASONS = {400: "Bad Request", 403: "Forbidden"}


@dataclass(eq=False)
class _Client:
    id: int
    websocket: WebSocket


class TokenBucket:
    """A rate limit: ``burst`` at once, then ``rate`` a second (:meth:`take` says whether one
    more is allowed)."""

    def __init__(
        self, rate: float, burst: float, clock: Callable[[], float] = time.monotonic
    ) -> None:
        if not (rate > 0 and burst >= 1):
            raise ValueError(f"need rate > 0 and burst >= 1, got {rate} and {burst}")
        self.rate = float(rate)
        self.burst = float(burst)
        self._clock = clock
        self._tokens = self.burst
        self._last = clock()

    def take(self) -> bool:
        """Spend one token if there is one; False when the limit is reached."""
        now = self._clock()
        self._tokens = min(self.burst, self._tokens + (now - self._last) * self.rate)
        self._last = now
        if self._tokens < 1.0:
            return False
        self._tokens -= 1.0
        return True


class StopLine:
    """Runs ``stop(reason)`` in a thread of its own (on the real robot a stop talks to the serial
    link), so a stop never waits behind other work. A stop asked for while another one waits to
    start joins it: however many pages press stop, at most one runs and one waits. The stop that
    runs carries the reason of every request it answers (``"; "``-separated, each once), so a
    stop button pressed while the controlling page's closing stop waited is named too.

    A stop that can start at once is handed the interpreter: the event loop waits for it,
    blocked, for up to :data:`HAND_OVER_S` before it goes on. Otherwise a loop kept busy (a page
    flooding frames that are parsed a slice per turn) holds the interpreter lock, and the stop's
    thread gets it only between the loop's turns, a few milliseconds at a time: a tenth of a
    second and more for a stop that takes a millisecond of work."""

    REASON_SEPARATOR = "; "
    HAND_OVER_S = 0.02
    """[s] the longest the event loop waits, blocked, for a stop that could start at once (a
    stop that hangs, a serial link gone quiet, holds the loop no longer; a stop asked for while
    another runs or waits does not block the loop at all)."""

    def __init__(self, stop: Callable[[str], None]) -> None:
        self._stop = stop
        self._executor = ThreadPoolExecutor(max_workers=1, thread_name_prefix="lfd-track stop")
        self._lock = threading.Lock()
        self._waiting: Future[None] | None = None
        self._reasons: list[str] = []  # of the waiting stop
        self._running = False

    def request(self, reason: str) -> Future[None]:
        """Ask for a stop; the future is done once the robot was told to stop (by a stop that
        started after this request)."""
        return self._ask(reason)[0]

    def _ask(self, reason: str) -> tuple[Future[None], bool]:
        """:meth:`request`, and whether the stop asked for can start at once (none runs or
        waits)."""
        with self._lock:
            if self._waiting is None or self._waiting.done():
                idle = not self._running
                self._reasons = [reason]
                self._waiting = self._executor.submit(self._run)
                return self._waiting, idle
            if reason not in self._reasons:
                self._reasons.append(reason)
            return self._waiting, False

    async def stop(self, reason: str) -> None:
        """Stop, and wait until it is done (without holding up the event loop for longer than
        :data:`HAND_OVER_S`). Cancelling the wait does not cancel the stop (other pages' stops
        may have joined it)."""
        done, idle = self._ask(reason)
        if idle:
            wait([done], timeout=self.HAND_OVER_S)  # releases the interpreter lock meanwhile
        await asyncio.shield(asyncio.wrap_future(done))

    def _run(self) -> None:
        with self._lock:
            self._waiting = None  # a stop asked for from now on runs after this one
            reasons, self._reasons = self._reasons, []
            self._running = True
        try:
            self._stop(self.REASON_SEPARATOR.join(reasons))
        finally:
            with self._lock:
                self._running = False


class ControlDesk:
    """Who may move the robot: one controlling page at a time, every other page watches.

    The first page to claim control gets it; when it leaves, its lease ends and control is free
    for the next claim (the caller stops the robot). Thread-safe.
    """

    def __init__(self, session: TeachingSession) -> None:
        self.session = session
        self._lock = threading.Lock()
        self._clients: dict[int, _Client] = {}
        self._controller: int | None = None
        self._ids = itertools.count(1)

    def __len__(self) -> int:
        with self._lock:
            return len(self._clients)

    def join(self, websocket: WebSocket) -> _Client:
        client = _Client(next(self._ids), websocket)
        with self._lock:
            self._clients[client.id] = client
        return client

    def leave(self, client: _Client) -> bool:
        """``client`` left; True when it held control (its lease has ended: stop the robot)."""
        with self._lock:
            self._clients.pop(client.id, None)
            was_controller = self._controller == client.id
            if was_controller:
                self._controller = None
        if was_controller:
            # A closed tab sends no more heartbeats; stop now rather than when the lease ends.
            self.session.end_lease()
        return was_controller

    def claim(self, client: _Client) -> bool:
        """Give ``client`` control if it is free, or held by a page whose lease ran out (a phone
        that fell asleep keeps its socket but no longer holds the robot)."""
        lapsed = not self.session.status().get("lease_alive", True)
        with self._lock:
            if self._controller is None or lapsed:
                self._controller = client.id
            granted = self._controller == client.id
        if granted:
            self.session.heartbeat()
        return granted

    def is_controller(self, client: _Client) -> bool:
        with self._lock:
            return self._controller == client.id

    def snapshot(self, client: _Client, lease_alive: bool) -> dict[str, Any]:
        """What one page is told about control (``lease_alive``: the controller's lease)."""
        with self._lock:
            return {
                "role": "controller" if self._controller == client.id else "watcher",
                "control_free": self._controller is None or not lease_alive,
                "clients": len(self._clients),
            }


def _json_status(session: TeachingSession) -> dict[str, Any]:
    return {"backend": session.backend, "online": session.online, **session.status()}


def parse_message(received: Mapping[str, Any]) -> tuple[dict[str, Any] | None, str | None]:
    """A received WebSocket message as ``(message, None)``, or ``(None, error text)``."""
    text = received.get("text")
    if text is None:
        return None, "binary messages are not accepted"
    if len(text) > MAX_MESSAGE_CHARS:
        return None, f"message too long ({len(text)} characters, at most {MAX_MESSAGE_CHARS})"
    try:
        message = json.loads(text)
    except RecursionError:
        return None, "message nested too deeply"
    except ValueError as exc:
        return None, f"not JSON: {exc}"
    if not isinstance(message, dict):
        return None, "a message must be a JSON object"
    return message, None


def create_app(
    session: TeachingSession,
    *,
    token: str | None = None,
    fps: float = DEFAULT_FPS,
    max_pages: int = MAX_PAGES,
    message_rate: float | None = MESSAGE_RATE,
    message_burst: int = MESSAGE_BURST,
) -> ASGIApp:
    """The teaching station app for ``session``.

    ``token``: required on every request when set (any non-loopback listener must set one).
    ``fps``: [frames/s] camera-view rate per page.
    ``max_pages``: WebSockets open at once. ``message_rate`` [messages/s] and ``message_burst``:
    each page's message limit (None: no limit, for tests).
    """
    if not fps > 0:
        raise ValueError(f"fps must be positive, got {fps}")
    if max_pages < 1:
        raise ValueError(f"max_pages must be at least 1, got {max_pages}")
    if message_rate is not None:
        TokenBucket(message_rate, message_burst)  # checks them now, not at each page
    desk = ControlDesk(session)
    stop_line = StopLine(lambda reason: session.stop(reason))
    static = resources.files(__package__) / "static"
    page_template = (static / "index.html").read_text(encoding="utf-8")
    period_s = 1.0 / fps
    token_query = f"?token={token}" if token else ""
    # JSON in a data block of the page: "<" escaped, so no text in it can end the block.
    contract_json = json.dumps(page_contract()).replace("<", "\\u003c")
    too_many = f"too many messages: at most {message_burst} at once, {message_rate or 0:g} a second"

    async def index(request: Request) -> Response:
        page = (
            page_template.replace("__TOKEN__", html.escape(token or "", quote=True))
            .replace("__QUERY__", html.escape(token_query, quote=True))
            .replace("__BACKEND__", html.escape(session.backend))
            .replace("__ONLINE__", "true" if session.online else "false")
            .replace("__CONTRACT__", contract_json)
        )
        return HTMLResponse(page, headers=_SECURITY_HEADERS)

    async def static_file(request: Request) -> Response:
        name = request.path_params["name"]
        if name not in STATIC_FILES:
            return PlainTextResponse("404 Not Found\n", status_code=404)
        body = (static / name).read_bytes()
        return Response(body, media_type=STATIC_FILES[name], headers=_SECURITY_HEADERS)

    async def no_icon(request: Request) -> Response:
        return Response(status_code=204)  # browsers ask for one; the page has none

    async def status(request: Request) -> Response:
        return JSONResponse(_json_status(session), headers={"Cache-Control": "no-store"})

    async def stream(websocket: WebSocket, client: _Client) -> None:
        """Push the camera view at ``fps``, the top-down view when it changes, and the status."""
        top_seq = -1
        try:
            while True:
                view = session.latest_view()
                if view is not None:
                    await websocket.send_bytes(ViewTag.CAMERA + view.camera_jpeg)
                    if view.topdown_jpeg is not None and view.seq != top_seq:
                        await websocket.send_bytes(ViewTag.TOPDOWN + view.topdown_jpeg)
                        top_seq = view.seq
                status = _json_status(session)
                control = desk.snapshot(client, bool(status.get("lease_alive", True)))
                await websocket.send_text(
                    json.dumps({"type": ServerMessage.STATUS, **status, **control})
                )
                await asyncio.sleep(period_s)  # the stream's pace, not a wait for anything
        except (WebSocketDisconnect, RuntimeError, OSError):
            return  # the page went away; the receiving side cleans up

    def handle(client: _Client, message: dict[str, Any]) -> str | None:
        """Carry out one page message other than ``stop``; returns an error text, or None.

        On the event loop: each of these only sets state under the session's locks.
        """
        kind = message.get("type")
        if kind == ClientMessage.CLAIM:
            return None if desk.claim(client) else "another page controls the robot"
        if not desk.is_controller(client):
            return "watching only: another page controls the robot"
        if kind == ClientMessage.HEARTBEAT:
            session.heartbeat()
        elif kind == ClientMessage.PRESS:
            command = COMMAND_NAMES.get(str(message.get("command")))
            if command is None:
                return f"unknown command {_short(message.get('command'))}"
            session.heartbeat()
            session.press(command)
        elif kind == ClientMessage.RELEASE:
            session.release()
        elif kind == ClientMessage.PAUSE_LEARNING:
            paused = message.get("paused")
            if not isinstance(paused, bool):
                return f'"paused" must be true or false, got {_short(paused)}'
            session.set_learning_paused(paused)
        elif kind == ClientMessage.TAKEOVER:
            session.take_over()
        else:
            return f"unknown message type {_short(kind)}"
        return None

    async def respond(client: _Client, received: Mapping[str, Any]) -> str | None:
        """Carry out one received message; returns an error text for the page, or None."""
        message, error = parse_message(received)
        if message is None:
            return error
        try:
            if message.get("type") == ClientMessage.STOP:
                # Any page may stop the robot, and a stop never queues behind other work.
                await stop_line.stop("stop button")
                return None
            return handle(client, message)
        except ValueError as exc:  # the session refused (takeover without a policy)
            return str(exc)

    async def socket(websocket: WebSocket) -> None:
        if len(desk) >= max_pages:
            await websocket.send_denial_response(
                PlainTextResponse(
                    f"503 Service Unavailable: {max_pages} pages are open, the most at once\n",
                    status_code=503,
                )
            )
            return
        bucket = TokenBucket(message_rate, message_burst) if message_rate is not None else None
        client = desk.join(websocket)
        sender: asyncio.Task[None] | None = None
        try:
            await websocket.accept()
            sender = asyncio.create_task(stream(websocket, client))
            desk.claim(client)
            while True:
                received = await websocket.receive()
                if received["type"] == "websocket.disconnect" or sender.done():
                    break  # gone (the stream could not send): what is still queued is moot
                if bucket is not None and not bucket.take():
                    await websocket.close(1008, too_many)
                    break
                error = await respond(client, received)
                if error is not None:
                    await websocket.send_text(
                        json.dumps({"type": ServerMessage.ERROR, "message": error})
                    )
                # Hand the loop on: a message answered at once never yields by itself, so a
                # page sending without pause would hold every other page (and its stop) up.
                await asyncio.sleep(0)
        except (WebSocketDisconnect, RuntimeError, OSError):
            pass  # the page went away (RuntimeError: a send raced the close)
        finally:
            if sender is not None:
                sender.cancel()
            if desk.leave(client):
                # Awaited: a failed stop is logged (as any error of the page's), and the server
                # ends (then the session closes) only once the robot was told to stop.
                await stop_line.stop("the controlling page closed")

    app = Starlette(
        routes=[
            Route("/", index),
            Route("/static/{name}", static_file),
            Route("/api/status", status),
            Route("/favicon.ico", no_icon),
            WebSocketRoute("/ws", socket),
        ]
    )
    return AccessGuard(app, token)
