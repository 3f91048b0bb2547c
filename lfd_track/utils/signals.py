"""SIGTERM and SIGHUP handled like Ctrl-C, so a command's normal clean-up runs.

Their default action ends the process at once: a robot left driving on its lease, a terminal
left without echo, a recording without its footer, a staging folder or an empty file left
behind. Inside :func:`stop_signals_interrupt` they raise ``KeyboardInterrupt`` in the main
thread instead; with :func:`raise_terminated` as its handler SIGTERM raises :class:`Terminated`,
for commands that exit 143 rather than 130 for it (:func:`interrupted_exit_code`).
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

EXIT_INTERRUPTED = 130
"""Exit code after Ctrl-C (128 + SIGINT)."""
EXIT_TERMINATED = 143
"""Exit code after SIGTERM (128 + SIGTERM)."""

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


class Terminated(BaseException):
    """SIGTERM arrived: stop like Ctrl-C, keeping what was done (a BaseException like
    KeyboardInterrupt, so no ``except Exception`` takes it for a failure)."""


def raise_terminated(signum: int, frame: Any) -> None:
    """A SIGTERM handler: raise :class:`Terminated`."""
    raise Terminated()


def interrupted_exit_code(exc: BaseException) -> int:
    """The exit code of a command stopped by ``exc`` (Ctrl-C or SIGTERM); further SIGTERMs are
    ignored from now on, so the command's closing note is printed whole."""
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    return EXIT_TERMINATED if isinstance(exc, Terminated) else EXIT_INTERRUPTED
