"""Progress bars for long CLI work (tqdm on stderr; nothing at all when stderr is not a terminal).

The CLI reports progress through callbacks it passes to the work (``progress=``, ``on_step=``),
so the bars live here and in ``cli.py`` only, never in the library code that does the work.
"""

from __future__ import annotations

import sys
from typing import TextIO

from tqdm import tqdm


def progress_bar(
    total: float | None,
    label: str,
    *,
    unit: str = "it",
    enabled: bool = True,
    stream: TextIO | None = None,
    leave: bool = True,
) -> tqdm:
    """A tqdm bar on ``stream`` (default stderr), shown only on a terminal and when ``enabled``.

    ``total=None`` shows a running count (for work whose size is known only when it ends).
    Use as a context manager and call ``update(n)`` / ``set_postfix_str(text)`` on it.
    """
    stream = stream if stream is not None else sys.stderr
    on_terminal = bool(getattr(stream, "isatty", lambda: False)())
    return tqdm(
        total=total,
        desc=label,
        unit=unit,
        file=stream,
        disable=not (enabled and on_terminal),
        leave=leave,
        dynamic_ncols=True,
    )
