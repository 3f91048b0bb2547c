"""The WebSocket's message types are defined once (``lfd_track/web/contract.py``) and the page
reads them from the server: ``static/app.js`` names them only through the served contract.

A type hard-coded in the script, or renamed on one side only, fails here (and, in a browser,
the script's strict tables throw on a name the contract lacks).
"""

from __future__ import annotations

import json
import re
import urllib.request
from importlib import resources

import pytest

from lfd_track.web.contract import (
    COMMAND_NAMES,
    ClientMessage,
    ServerMessage,
    ViewTag,
    page_contract,
)

STATIC = resources.files("lfd_track.web") / "static"
SCRIPT = (STATIC / "app.js").read_text(encoding="utf-8")
PAGE = (STATIC / "index.html").read_text(encoding="utf-8")
TABLES = {"TO_SERVER": ClientMessage, "TO_PAGE": ServerMessage, "VIEW": ViewTag}
_LITERAL = r"""(?:"[^"]*"|'[^']*'|`[^`]*`|\d+)"""


def _code(script: str) -> str:
    """The script without its comments (line comments outside strings are enough here)."""
    return "\n".join(re.sub(r"\s//\s.*$", "", line) for line in script.splitlines())


def test_the_script_hard_codes_no_message_type() -> None:
    code = _code(SCRIPT)
    sent = [t for t in re.findall(rf"\btype\s*:\s*({_LITERAL})", code) if "/" not in t]
    assert not sent, f"messages sent with a literal type: {sent}"  # ("/": a Blob's MIME type)
    assert not re.findall(rf"\.type\s*[!=]==?\s*{_LITERAL}", code), "a literal type compared"
    assert not re.findall(rf"bytes\[0\]\s*[!=]==?\s*{_LITERAL}", code), "a literal view tag"
    # (The buttons' data-action names and the claim button's id are the page's own: not types.)


def test_every_name_the_script_uses_is_in_the_contract_and_every_type_is_used() -> None:
    code = _code(SCRIPT)
    for table, enum in TABLES.items():
        used = set(re.findall(rf"\b{table}\.([A-Za-z_]\w*)", code))
        names = {member.name for member in enum}
        assert used <= names, f"app.js uses {table}.{sorted(used - names)}, not in {enum.__name__}"
        assert used == names, f"app.js never uses {table}.{sorted(names - used)}"
    contract = page_contract()
    assert contract["to_server"] == {m.name: m.value for m in ClientMessage}
    assert contract["to_page"] == {m.name: m.value for m in ServerMessage}
    assert contract["view_tags"] == {"CAMERA": ord("C"), "TOPDOWN": ord("T")}
    assert re.search(r"HEARTBEAT_MS = contract\.heartbeat_ms\b", code)


def test_the_page_drives_with_the_commands_the_server_knows() -> None:
    page_commands = set(re.findall(r'data-command="(\w+)"', PAGE))
    key_commands = set(re.findall(r'Arrow\w+:\s*"(\w+)"', SCRIPT))
    assert page_commands == set(COMMAND_NAMES) and key_commands <= page_commands


@pytest.mark.parametrize("token", [None, "t0k3n"])
def test_the_served_page_carries_the_contract(open_station, token) -> None:
    station = open_station(token=token)
    with urllib.request.urlopen(station.url, timeout=15.0) as response:
        page = response.read().decode()
    block = re.search(
        r'<script type="application/json" id="lfd-contract">(.*?)</script>', page, re.S
    )
    assert block is not None, page
    assert json.loads(block.group(1)) == page_contract()
    assert page.index('id="lfd-contract"') < page.index("static/app.js")  # read before the script


def test_the_server_handles_every_type_a_page_may_send(open_station) -> None:
    """Each :class:`ClientMessage` reaches its handler (none is an unknown type); a type the
    contract lacks is refused by name."""
    from websockets.sync.client import connect

    station = open_station()
    url = station.url.replace("http", "ws", 1) + "ws"
    errors: list[str] = []
    with connect(url, proxy=None, open_timeout=15.0) as ws:
        for kind in ClientMessage:
            if kind is not ClientMessage.STOP:
                ws.send(json.dumps({"type": kind.value}))
        ws.send(json.dumps({"type": "no-such-type"}))  # the end marker: always an error
        while not errors or not errors[-1].startswith("unknown message type 'no-such"):
            data = json.loads(message) if isinstance(message := ws.recv(timeout=15.0), str) else {}
            if data.get("type") == ServerMessage.ERROR:
                errors.append(data["message"])
    assert not [e for e in errors[:-1] if e.startswith("unknown message type")], errors
