"""What ``lfd_track/web/server.py`` relies on inside uvicorn, checked against the installed one.

The station's connection guards extend two of uvicorn's protocol classes, which are not public
API. This file fails, naming the missing piece, when an upgrade of uvicorn changes a method or
attribute that the guards override, call or read; ``web/server.py`` is the only module of the
package that imports uvicorn (checked below), so it is the only one to adapt.
"""

from __future__ import annotations

import ast
import asyncio
import inspect
from pathlib import Path

import pytest

pytest.importorskip("uvicorn")

import uvicorn  # noqa: E402
from uvicorn.protocols.http.h11_impl import H11Protocol  # noqa: E402
from uvicorn.protocols.websockets.websockets_sansio_impl import (  # noqa: E402
    WebSocketsSansIOProtocol,
)
from uvicorn.server import ServerState  # noqa: E402

import lfd_track  # noqa: E402

PACKAGE = Path(lfd_track.__file__).resolve().parent

# Methods the guards override or call through super(), with the parameters they pass.
HTTP_METHODS = {
    "connection_made": ["self", "transport"],
    "data_received": ["self", "data"],
    "on_response_complete": ["self"],
    "connection_lost": ["self", "exc"],
    "pause_writing": ["self"],
    "resume_writing": ["self"],
}
WS_METHODS = {
    "data_received": ["self", "data"],
    "connection_lost": ["self", "exc"],
    "pause_writing": ["self"],
    "resume_writing": ["self"],
    "handle_cont": ["self", "event"],
    "receive": ["self"],
    "send": ["self", "message"],
}
# Attributes the guards read or set, present once the protocol is constructed.
HTTP_ATTRIBUTES = ["loop", "transport", "scope", "conn"]
WS_ATTRIBUTES = [
    "loop", "transport", "conn", "queue", "frames", "close_sent", "close_timer",
    "handshake_complete", "read_paused",
]  # fmt: skip
CONSTRUCTOR = ["self", "config", "server_state", "app_state", "_loop"]


async def _app(scope, receive, send):  # pragma: no cover - never called
    raise AssertionError


def _constructed(cls):
    loop = asyncio.new_event_loop()
    config = uvicorn.Config(_app, loop="asyncio")
    config.load()
    try:
        return cls(config, ServerState(), {}, _loop=loop)
    finally:
        loop.close()


@pytest.mark.parametrize(
    ("cls", "methods", "attributes"),
    [
        (H11Protocol, HTTP_METHODS, HTTP_ATTRIBUTES),
        (WebSocketsSansIOProtocol, WS_METHODS, WS_ATTRIBUTES),
    ],
    ids=["http", "websocket"],
)
def test_the_protocol_classes_have_what_the_guards_use(cls, methods, attributes):
    assert list(inspect.signature(cls.__init__).parameters) == CONSTRUCTOR, cls
    for name, parameters in methods.items():
        method = getattr(cls, name, None)
        assert callable(method), f"{cls.__name__}.{name} is gone"
        assert list(inspect.signature(method).parameters) == parameters, f"{cls.__name__}.{name}"
    protocol = _constructed(cls)
    missing = [name for name in attributes if not hasattr(protocol, name)]
    assert not missing, f"{cls.__name__} lacks {missing}"


def test_the_websocket_connection_can_fail_and_hand_over_its_bytes():
    conn = _constructed(WebSocketsSansIOProtocol).conn
    assert callable(conn.fail) and callable(conn.data_to_send)


def test_config_takes_the_protocol_factories_the_server_passes():
    parameters = inspect.signature(uvicorn.Config.__init__).parameters
    assert {"http", "ws", "loop"} <= set(parameters)
    server = uvicorn.Server(uvicorn.Config(_app))
    assert hasattr(server, "started") and hasattr(server, "should_exit")
    assert "sockets" in inspect.signature(server.run).parameters


def test_only_the_server_module_imports_uvicorn():
    importers = []
    for path in sorted(PACKAGE.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names = []
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and not node.level:
                names = [node.module or ""]
            if any(name.split(".")[0] == "uvicorn" for name in names):
                importers.append(path.relative_to(PACKAGE).as_posix())
    assert set(importers) == {"web/server.py"}
