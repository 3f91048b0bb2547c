"""The station's parts without a browser: lease, browser commander, host and URL helpers."""

from __future__ import annotations

import threading
import time

import pytest

from lfd_track.core.commands import Command
from lfd_track.web.app import is_loopback
from lfd_track.web.commander import MAX_QUEUED, BrowserCommander
from lfd_track.web.contract import Lease
from lfd_track.web.server import station_url


def test_lease_expires_once_after_the_last_renewal_and_rearms() -> None:
    expired = threading.Event()
    calls = []

    def on_expire() -> None:
        calls.append(time.monotonic())
        expired.set()

    lease = Lease(on_expire, duration_s=0.2)
    try:
        assert not lease.alive  # nobody holds it yet: commands must not move the robot
        start = time.monotonic()
        lease.renew()
        assert lease.alive
        assert expired.wait(5.0)
        assert calls[0] - start >= 0.2 and not lease.alive
        expired.clear()
        lease.renew()  # a page that wakes up holds it again
        assert lease.alive and expired.wait(5.0) and len(calls) == 2
    finally:
        lease.close()


def test_a_revoked_lease_never_calls_back() -> None:
    expired = threading.Event()
    lease = Lease(expired.set, duration_s=0.05)
    try:
        lease.renew()
        lease.revoke()
        assert not lease.alive
        assert not expired.wait(0.3)  # bounded check that nothing fires (the lease was 0.05 s)
    finally:
        lease.close()


def test_lease_rejects_a_non_positive_duration() -> None:
    with pytest.raises(ValueError, match="positive"):
        Lease(lambda: None, duration_s=0)


def test_each_press_runs_once_and_a_held_press_repeats() -> None:
    commander = BrowserCommander()
    assert commander.next_command() is None and not commander.pending
    for _ in range(3):  # three quick taps before the loop looks
        commander.press(Command.FORWARD)
        commander.release()
    assert [commander.next_command() for _ in range(4)] == [Command.FORWARD] * 3 + [None]
    commander.press(Command.LEFT)  # held down
    assert [commander.next_command() for _ in range(3)] == [Command.LEFT] * 3
    commander.release()
    assert commander.next_command() is None
    for _ in range(MAX_QUEUED + 3):
        commander.press(Command.RIGHT)
    commander.clear()
    assert commander.next_command() is None and not commander.pending


def test_loopback_detection_and_the_printed_url() -> None:
    assert all(is_loopback(h) for h in ("localhost", "127.0.0.1", "127.1.2.3", "::1", "[::1]"))
    assert not any(is_loopback(h) for h in ("0.0.0.0", "192.168.1.5", "example.org", "::"))
    assert station_url("127.0.0.1", 8765, None) == "http://127.0.0.1:8765/"
    assert station_url("::1", 80, "abc") == "http://[::1]:80/?token=abc"
    assert station_url("0.0.0.0", 8765, "t").endswith(":8765/?token=t")
