"""Screenshots of the teaching station for the README, taken by the test browser.

Serves ``lfd-track teach --online`` (simulator, training track) on a free loopback port, gives
a short demonstration through the page (Debian's ``chromium`` driven by Playwright, as in
``tests/web``), then photographs the page at a phone-sized and a laptop-sized viewport. The
phone is the controlling page; the laptop watches.

Run: ``.venv/bin/python scripts/teach_screenshots.py`` — writes ``docs/teach_phone.png`` and
``docs/teach_laptop.png`` and prints the live view's frame rate seen by the phone page.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from playwright.sync_api import sync_playwright

from lfd_track.cli import build_parser
from lfd_track.cli.teach import teach_config
from lfd_track.web.app import create_app
from lfd_track.web.server import StationServer, bind_socket, station_url
from lfd_track.web.session import open_session

CHROMIUM = "/usr/bin/chromium"
CHROMIUM_ARGS = [
    "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
]  # fmt: skip
DOCS = Path(__file__).resolve().parents[1] / "docs"
DEMONSTRATION = ["forward"] * 5 + ["left", "right", "forward"]


def wait_for(page, expression: str, timeout_s: float = 20.0) -> None:
    """Poll a page expression until it is truthy (the page's CSP forbids Playwright's eval wait)."""
    deadline = time.monotonic() + timeout_s
    while not page.evaluate(f"() => {expression}"):
        if time.monotonic() > deadline:
            raise TimeoutError(expression)
        time.sleep(0.05)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=DOCS, help="folder for the PNGs")
    out_dir = parser.parse_args().out
    out_dir.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        argv = ["teach", "--online", "--port", "0", "--out", f"{tmp}/taught.lfdemo"]
        session = open_session(teach_config(build_parser().parse_args(argv)))
        server = StationServer(create_app(session), bind_socket("127.0.0.1", 0)).start()
        url = station_url("127.0.0.1", server.port, None)
        try:
            with sync_playwright() as playwright:
                browser = playwright.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
                phone = browser.new_page(
                    viewport={"width": 390, "height": 844}, device_scale_factor=2, has_touch=True
                )
                phone.goto(url)
                wait_for(phone, "window.lfd && window.lfd.role === 'controller'")
                for given, command in enumerate(DEMONSTRATION, start=1):
                    phone.click(f'[data-command="{command}"]')
                    wait_for(phone, f"window.lfd.status.cases === {given}")
                wait_for(phone, "!window.lfd.status.driving")
                start = phone.evaluate("() => [window.lfd.frames, performance.now()]")
                wait_for(phone, f"performance.now() - {start[1]} > 3000")
                end = phone.evaluate("() => [window.lfd.frames, performance.now()]")
                fps = (end[0] - start[0]) / ((end[1] - start[1]) / 1000)
                phone.screenshot(path=str(out_dir / "teach_phone.png"), full_page=True)
                laptop = browser.new_page(viewport={"width": 1280, "height": 760})
                laptop.goto(url)
                wait_for(laptop, "window.lfd && window.lfd.frames > 2 && window.lfd.status")
                laptop.screenshot(path=str(out_dir / "teach_laptop.png"))
                browser.close()
        finally:
            server.shutdown()
            session.close()
    print(f"live view on the phone page: {fps:.1f} frames/s; screenshots in {out_dir}")


if __name__ == "__main__":
    main()
