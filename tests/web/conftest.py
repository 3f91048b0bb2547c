"""A real headless Chromium (Debian's ``chromium`` driven by Playwright) and teaching stations.

Without Playwright or ``/usr/bin/chromium`` the browser tests are skipped, except under CI=true,
where a missing browser is a failure: CI installs it (``.ci/run``), so its absence is a broken
build. Browsers are never downloaded: Playwright launches the system's Chromium.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
from lfd_test_support import unavailable

CHROMIUM = Path("/usr/bin/chromium")
CHROMIUM_ARGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]


def _browser_unavailable(reason: str) -> None:
    unavailable(f"the teaching-station browser tests need {reason}")


@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
    """One headless Chromium per test module."""
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        _browser_unavailable("Playwright: pip install playwright (part of the test extra)")
    if not CHROMIUM.is_file():
        _browser_unavailable(f"{CHROMIUM}: apt-get install chromium")
    with sync_playwright() as playwright:
        chromium = playwright.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_ARGS)
        try:
            yield chromium
        finally:
            chromium.close()


@dataclass
class Station:
    """A running teaching station: its URL, session, server and output file."""

    url: str
    session: Any
    server: Any
    out: Path


@pytest.fixture
def open_station(tmp_path: Path) -> Iterator[Callable[..., Station]]:
    """``open_station(*teach_args, token=None, app_options=None, server_options=None)``: a
    station served on a free loopback port.

    ``teach_args`` are ``lfd-track teach`` flags (``--out`` defaults to a file in tmp_path,
    ``--period`` to 0.1 s: in the simulator that only paces the commands, so tests run faster);
    ``app_options`` go to ``create_app``, ``server_options`` to ``StationServer``.
    """
    from lfd_track.cli import build_parser
    from lfd_track.cli.teach import teach_config
    from lfd_track.web.app import create_app
    from lfd_track.web.server import StationServer, bind_socket, station_url
    from lfd_track.web.session import open_session

    opened: list[Station] = []

    def open_(
        *teach_args: str,
        token: str | None = None,
        app_options: dict[str, Any] | None = None,
        server_options: dict[str, Any] | None = None,
    ) -> Station:
        argv = ["teach", "--port", "0", *teach_args]
        if "--period" not in teach_args:
            argv += ["--period", "0.1"]  # the simulator's pace: four commands per robot period
        if "--out" not in teach_args:
            argv += ["--out", str(tmp_path / f"taught{len(opened)}.lfdemo")]
        args = build_parser().parse_args(argv)
        session = open_session(teach_config(args))
        server = StationServer(
            create_app(session, token=token, **(app_options or {})),
            bind_socket("127.0.0.1", 0),
            **(server_options or {}),
        )
        station = Station(
            station_url("127.0.0.1", server.port, token), session, server, Path(args.out)
        )
        opened.append(station)
        server.start()
        return station

    try:
        yield open_
    finally:
        for station in opened:
            station.server.shutdown()
            station.session.close()
