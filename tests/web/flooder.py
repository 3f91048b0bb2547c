"""A hostile page for the station's tests: floods the WebSocket with one message as fast as it
can (reading whatever comes back), reconnecting whenever the server closes it, until its
standard input closes.

``python flooder.py WS_URL junk|heartbeat|press`` prints ``flooding`` once connected, ``closed
CODE REASON`` each time the server closes it (as it happens), then at the end one JSON line:
``{"connects": n, "refused": n, "closes": {"CODE REASON": n}}``.
"""

from __future__ import annotations

import asyncio
import json
import sys
import threading
import time

from websockets.asyncio.client import connect
from websockets.exceptions import ConnectionClosed, InvalidStatus

MESSAGES = {
    "junk": "{bad",
    "heartbeat": json.dumps({"type": "heartbeat"}),
    "press": json.dumps({"type": "press", "command": "left"}),
}
MAX_S = 60.0  # guard: a flooder whose test died does not run on


async def drain(ws) -> None:
    try:
        async for _ in ws:
            pass
    except ConnectionClosed:
        pass


async def flood(url: str, message: str, done: threading.Event) -> dict:
    report: dict = {"connects": 0, "refused": 0, "closes": {}}
    give_up = time.monotonic() + MAX_S
    while not done.is_set() and time.monotonic() < give_up:
        try:
            async with connect(
                url,
                max_size=None,
                open_timeout=10,
                close_timeout=0.2,
                ping_interval=None,
                proxy=None,
            ) as ws:
                report["connects"] += 1
                if report["connects"] == 1:
                    print("flooding", flush=True)
                reader = asyncio.create_task(drain(ws))
                try:
                    while not done.is_set():
                        for _ in range(50):
                            await ws.send(message)
                        await asyncio.sleep(0)
                except ConnectionClosed as exc:
                    key = f"{exc.rcvd.code} {exc.rcvd.reason}" if exc.rcvd else "no close frame"
                    report["closes"][key] = report["closes"].get(key, 0) + 1
                    print("closed", key, flush=True)
                reader.cancel()
        except InvalidStatus:
            report["refused"] += 1
            await asyncio.sleep(0.01)
        except (OSError, TimeoutError, ConnectionClosed):
            await asyncio.sleep(0.01)
    return report


def main() -> None:
    url, kind = sys.argv[1], sys.argv[2]
    done = threading.Event()
    threading.Thread(target=lambda: (sys.stdin.read(), done.set()), daemon=True).start()
    report = asyncio.run(flood(url, MESSAGES[kind], done))
    print(json.dumps(report), flush=True)


if __name__ == "__main__":
    main()
