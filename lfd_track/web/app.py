"""The teaching station's ASGI app (Starlette): the page, the status API and the WebSocket.

Routes (every one behind :class:`AccessGuard`):

- ``GET /`` — the page (``static/index.html`` with the token filled in);
- ``GET /static/<file>`` — its script and style sheet, shipped in the package;
- ``GET /api/status`` — the session's status as JSON (see :data:`protocol.STATUS_FIELDS`);
- ``WS /ws`` — commands and heartbeats in, frames and status out.

WebSocket protocol. The page sends JSON text messages ``{"type": ...}``:

==================  =============================================================================
``claim``           take control if no other page holds it, or its holder's lease ran out (every
                    page claims on connect, so the first one gets control)
``heartbeat``       the controlling page is alive (every 250 ms; 1 s without one stops the robot)
``press``           ``{"command": "forward"|"left"|"right"}``: run it now and while held
``release``         the command button was let go
``stop``            stop at once (any page may stop the robot, watching or controlling)
``pause-learning``  ``{"paused": true|false}``
``takeover``        let the policy drive (``--online``)
==================  =============================================================================

The server sends binary messages ``b"C" + JPEG`` (camera view with the road-value overlay) at
``fps`` and ``b"T" + JPEG`` (the simulator's top-down view) when it changed, and text messages
``{"type": "status", ...}`` (the session's status plus ``role``: ``"controller"`` or
``"watcher"``, ``control_free``, ``clients``) and ``{"type": "error", "message": ...}``.
Only the controlling page's commands move the robot; the others watch.
"""

from __future__ import annotations

import asyncio
import html
import ipaddress
import itertools
import json
import secrets
import threading
from dataclasses import dataclass
from importlib import resources
from typing import Any
from urllib.parse import parse_qs, urlsplit

from starlette.applications import Starlette
from starlette.requests import Request
from starlette.responses import HTMLResponse, JSONResponse, PlainTextResponse, Response
from starlette.routing import Route, WebSocketRoute
from starlette.types import ASGIApp, Receive, Scope, Send
from starlette.websockets import WebSocket, WebSocketDisconnect

from .cli import DEFAULT_FPS
from .protocol import COMMAND_NAMES, TeachingSession

STATIC_FILES = {
    "app.js": "text/javascript; charset=utf-8",
    "style.css": "text/css; charset=utf-8",
}
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


def _host_name(host_header: str) -> str:
    """The host part of a ``Host`` header value (``[::1]:8765`` → ``::1``)."""
    return urlsplit(f"//{host_header}").hostname or ""


class AccessGuard:
    """ASGI middleware: token, ``Host`` and ``Origin`` checks on every request and WebSocket.

    - With a ``token``, every request must carry ``?token=<token>``; otherwise 403.
    - Without one (loopback only), the ``Host`` header must name a loopback host, so a web page
      elsewhere cannot reach the robot through DNS rebinding.
    - A WebSocket whose ``Origin`` is another site than the ``Host`` it connects to is refused:
      any page open in the same browser could otherwise drive the robot.

    A refused WebSocket is closed before it is accepted, which the server answers with HTTP 403.
    """

    def __init__(self, app: ASGIApp, token: str | None) -> None:
        self.app = app
        self.token = token

    def _problem(self, scope: Scope) -> str | None:
        headers = {k.decode("latin-1"): v.decode("latin-1") for k, v in scope["headers"]}
        host = headers.get("host", "")
        if self.token is None:
            if not is_loopback(_host_name(host)):
                return "this station serves loopback only"
        else:
            given = parse_qs(scope.get("query_string", b"").decode("latin-1")).get("token", [""])
            if not secrets.compare_digest(given[-1].encode(), self.token.encode()):
                return "missing or wrong token: open the URL the teach command printed"
        if scope["type"] == "websocket":
            origin = headers.get("origin")
            if origin is not None and urlsplit(origin).netloc.lower() != host.lower():
                return "cross-site WebSocket refused"
        return None

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        problem = self._problem(scope)
        if problem is None:
            await self.app(scope, receive, send)
        elif scope["type"] == "http":
            await PlainTextResponse(f"403 Forbidden: {problem}\n", status_code=403)(
                scope, receive, send
            )
        else:
            await send({"type": "websocket.close", "code": 1008, "reason": problem})


@dataclass(eq=False)
class _Client:
    id: int
    websocket: WebSocket


class ControlDesk:
    """Who may move the robot: one controlling page at a time, every other page watches.

    The first page to claim control gets it; when it leaves, the robot stops and control is
    free for the next claim. Thread-safe.
    """

    def __init__(self, session: TeachingSession) -> None:
        self.session = session
        self._lock = threading.Lock()
        self._clients: dict[int, _Client] = {}
        self._controller: int | None = None
        self._ids = itertools.count(1)

    def join(self, websocket: WebSocket) -> _Client:
        client = _Client(next(self._ids), websocket)
        with self._lock:
            self._clients[client.id] = client
        return client

    def leave(self, client: _Client) -> None:
        with self._lock:
            self._clients.pop(client.id, None)
            was_controller = self._controller == client.id
            if was_controller:
                self._controller = None
        if was_controller:
            # A closed tab sends no more heartbeats; stop now rather than when the lease ends.
            self.session.end_lease()
            self.session.stop("the controlling page closed")

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


def create_app(
    session: TeachingSession, *, token: str | None = None, fps: float = DEFAULT_FPS
) -> ASGIApp:
    """The teaching station app for ``session``.

    ``token``: required on every request when set (any non-loopback listener must set one).
    ``fps``: [frames/s] camera-view rate per page.
    """
    if not fps > 0:
        raise ValueError(f"fps must be positive, got {fps}")
    desk = ControlDesk(session)
    static = resources.files(__package__) / "static"
    page_template = (static / "index.html").read_text(encoding="utf-8")
    period_s = 1.0 / fps
    token_query = f"?token={token}" if token else ""

    async def index(request: Request) -> Response:
        page = (
            page_template.replace("__TOKEN__", html.escape(token or "", quote=True))
            .replace("__QUERY__", html.escape(token_query, quote=True))
            .replace("__BACKEND__", html.escape(session.backend))
            .replace("__ONLINE__", "true" if session.online else "false")
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
                    await websocket.send_bytes(b"C" + view.camera_jpeg)
                    if view.topdown_jpeg is not None and view.seq != top_seq:
                        await websocket.send_bytes(b"T" + view.topdown_jpeg)
                        top_seq = view.seq
                status = _json_status(session)
                control = desk.snapshot(client, bool(status.get("lease_alive", True)))
                await websocket.send_text(json.dumps({"type": "status", **status, **control}))
                await asyncio.sleep(period_s)  # the stream's pace, not a wait for anything
        except (WebSocketDisconnect, RuntimeError, OSError):
            return  # the page went away; the receiving side cleans up

    def handle(client: _Client, message: dict[str, Any]) -> str | None:
        """Carry out one page message; returns an error text for the page, or None."""
        kind = message.get("type")
        if kind == "claim":
            return None if desk.claim(client) else "another page controls the robot"
        if kind == "stop":
            session.stop("stop button")
            return None
        if not desk.is_controller(client):
            return "watching only: another page controls the robot"
        if kind == "heartbeat":
            session.heartbeat()
        elif kind == "press":
            command = COMMAND_NAMES.get(str(message.get("command")))
            if command is None:
                return f"unknown command {message.get('command')!r}"
            session.heartbeat()
            session.press(command)
        elif kind == "release":
            session.release()
        elif kind == "pause-learning":
            session.set_learning_paused(bool(message.get("paused")))
        elif kind == "takeover":
            session.take_over()
        else:
            return f"unknown message type {kind!r}"
        return None

    async def socket(websocket: WebSocket) -> None:
        await websocket.accept()
        client = desk.join(websocket)
        sender = asyncio.create_task(stream(websocket, client))
        try:
            await asyncio.to_thread(desk.claim, client)
            while True:
                received = await websocket.receive()
                if received["type"] == "websocket.disconnect":
                    break
                try:
                    message = json.loads(received.get("text") or "")
                    if not isinstance(message, dict):
                        raise ValueError("a message must be a JSON object")
                    # In a worker thread: a stop talks to the robot's serial link. One message
                    # at a time, so a press and its release keep their order.
                    error = await asyncio.to_thread(handle, client, message)
                except ValueError as exc:  # bad JSON, or the session refused
                    error = str(exc)
                if error is not None:
                    await websocket.send_text(json.dumps({"type": "error", "message": error}))
        except (WebSocketDisconnect, RuntimeError):
            pass  # the page went away (RuntimeError: a send raced the close)
        finally:
            sender.cancel()
            await asyncio.to_thread(desk.leave, client)

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
