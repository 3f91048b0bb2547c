"""A small progress bar for long CLI work (stderr; quiet, line-based output when not a terminal)."""

from __future__ import annotations

import sys
import time
from typing import TextIO


class ProgressBar:
    """``with ProgressBar(total, "evolving") as bar: bar.update(n, "note")``."""

    def __init__(
        self, total: int, label: str, *, stream: TextIO | None = None, enabled: bool = True
    ) -> None:
        self.total = max(int(total), 1)
        self.label = label
        self.stream = stream or sys.stderr
        self.enabled = enabled
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self._start = time.perf_counter()
        self._last_decile = -1
        self.done = 0

    def update(self, done: int, note: str = "") -> None:
        """Show ``done`` of ``total`` (and a short note)."""
        self.done = done
        if not self.enabled:
            return
        frac = min(done / self.total, 1.0)
        elapsed = time.perf_counter() - self._start
        if self.tty:
            width = 28
            filled = int(round(frac * width))
            bar = "#" * filled + "-" * (width - filled)
            self.stream.write(
                f"\r{self.label} [{bar}] {done}/{self.total} {elapsed:5.0f}s {note}\033[K"
            )
            self.stream.flush()
        else:
            decile = int(frac * 10)
            if decile != self._last_decile:
                self._last_decile = decile
                self.stream.write(f"{self.label}: {done}/{self.total} ({elapsed:.0f} s) {note}\n")
                self.stream.flush()

    def __enter__(self) -> ProgressBar:
        return self

    def __exit__(self, *exc: object) -> None:
        if self.enabled and self.tty:
            self.stream.write("\n")
            self.stream.flush()
