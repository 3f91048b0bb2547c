"""The station's server uses uvicorn's public API only, and its guards hold on any uvicorn.

``lfd_track/web/server.py`` is the only module that imports uvicorn; it uses ``uvicorn.Config``
(options checked against the installed uvicorn below) and ``uvicorn.Server`` (``serve``,
``started``, ``should_exit``). uvicorn's protocols are driven only through the methods of
``asyncio.Protocol``, and the guards see the app through ASGI: nothing ties them to one uvicorn
release, so the requirement has no upper bound. The hostile-client tests
(``test_hostile_clients.py``) show the guards work on the installed uvicorn.
"""

from __future__ import annotations

import ast
import asyncio
import inspect
import re
import tomllib
from pathlib import Path

import pytest

pytest.importorskip("uvicorn")

import uvicorn  # noqa: E402

import lfd_track  # noqa: E402
from lfd_track.web import server as station_server  # noqa: E402

PACKAGE = Path(lfd_track.__file__).resolve().parent
SERVER = PACKAGE / "web" / "server.py"
GUARDS = PACKAGE / "web" / "guards.py"
REPO = PACKAGE.parent
PROTOCOL_METHODS = {
    name for name in dir(asyncio.Protocol) if not name.startswith("_")
}  # connection_made, data_received, eof_received, pause/resume_writing, connection_lost


def _tree(path: Path = SERVER) -> ast.Module:
    return ast.parse(path.read_text(encoding="utf-8"))


def test_only_the_server_module_imports_uvicorn_and_only_its_top_level() -> None:
    importers = []
    for path in sorted(PACKAGE.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names = []
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and not node.level:
                names = [node.module or ""]
            for name in names:
                if name.split(".")[0] == "uvicorn":
                    importers.append((path.relative_to(PACKAGE).as_posix(), name))
    assert importers == [("web/server.py", "uvicorn")], importers


def test_the_server_uses_only_uvicorns_public_names() -> None:
    used = {
        node.attr
        for node in ast.walk(_tree())
        if isinstance(node, ast.Attribute)
        and isinstance(node.value, ast.Name)
        and node.value.id == "uvicorn"
    }
    assert used == {"Config", "Server"}
    on_server = {
        node.attr
        for node in ast.walk(_tree())
        if isinstance(node, ast.Attribute)
        and isinstance(node.value, ast.Attribute)
        and node.value.attr == "_server"
    }
    assert on_server == {"serve", "started", "should_exit"}, on_server
    server = uvicorn.Server(uvicorn.Config(object()))
    assert not server.started and not server.should_exit
    assert "sockets" in inspect.signature(server.serve).parameters


def test_the_config_options_the_server_passes_are_uvicorns() -> None:
    (call,) = [
        node
        for node in ast.walk(_tree())
        if isinstance(node, ast.Call)
        and isinstance(node.func, ast.Attribute)
        and node.func.attr == "Config"
    ]
    passed = {keyword.arg for keyword in call.keywords}
    accepted = set(inspect.signature(uvicorn.Config.__init__).parameters)
    assert passed <= accepted, passed - accepted
    sock = station_server.bind_socket("127.0.0.1", 0)
    try:
        config = station_server.StationServer(object(), sock)._server.config
        assert config.ws_max_size == station_server.WS_MAX_BYTES
        assert config.h11_max_incomplete_event_size == station_server.MAX_HEADER_BYTES
        assert config.ws_ping_interval is None and not config.ws_per_message_deflate
    finally:
        sock.close()


def test_uvicorns_protocols_are_driven_as_asyncio_protocols_only() -> None:
    """Whatever uvicorn's server makes is used through ``asyncio.Protocol``'s methods: nothing
    of its internals (attributes, other methods) is read, set or overridden."""
    on_inner = {
        node.attr
        for node in ast.walk(_tree(GUARDS))
        if isinstance(node, ast.Attribute)
        and isinstance(node.value, ast.Attribute)
        and node.value.attr == "inner"
    }
    assert on_inner and on_inner <= PROTOCOL_METHODS, on_inner - PROTOCOL_METHODS
    bases = {
        ast.unparse(base)
        for path in (SERVER, GUARDS)
        for node in ast.walk(_tree(path))
        if isinstance(node, ast.ClassDef)
        for base in node.bases
    }
    assert not [base for base in bases if "uvicorn" in base and base != "uvicorn.Server"]
    assert "uvicorn.Server" not in bases  # not even the public class is subclassed


def test_the_uvicorn_requirement_has_no_upper_bound() -> None:
    project = tomllib.loads((REPO / "pyproject.toml").read_text(encoding="utf-8"))
    requirements = project["project"]["dependencies"] + [
        requirement
        for extra in project["project"].get("optional-dependencies", {}).values()
        for requirement in extra
    ]
    uvicorn_lines = [r for r in requirements if re.match(r"uvicorn\b", r)]
    assert uvicorn_lines, requirements
    for line in uvicorn_lines:
        assert ">=" in line and "<" not in line.replace(">=", ""), line
