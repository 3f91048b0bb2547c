"""SIGTERM and SIGHUP handled like Ctrl-C, so a command's normal clean-up runs.

Their default action ends the process at once: a robot left driving on its lease, a terminal
left without echo, a recording without its footer or an empty one left behind. Inside
:func:`stop_signals_interrupt` they raise ``KeyboardInterrupt`` in the main thread instead.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

STOP_SIGNALS = (signal.SIGTERM, signal.SIGHUP)
"""Signals that stop a command like Ctrl-C (``kill PID``, a closed terminal)."""


@contextmanager
def stop_signals_interrupt() -> Iterator[None]:
    """Make SIGTERM and SIGHUP raise ``KeyboardInterrupt`` in the main thread, as Ctrl-C does;
    the previous handlers are restored on leaving. Outside the main thread (which alone may set
    handlers) it changes nothing."""

    def interrupt(signum: int, frame: Any) -> None:
        raise KeyboardInterrupt

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {signum: signal.signal(signum, interrupt) for signum in STOP_SIGNALS}
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
