"""Optional features and the extra that installs each: one line to run when one is missing.

``pip install lfd-track`` installs the simulator, the paper pipeline and the benchmark; the
teaching station, the serial link, video files, the CMA-ES learner, Ray studies and the
simulator's window each need an extra (``pyproject.toml``, ``[project.optional-dependencies]``).
A module of such a feature imports its third-party modules inside :func:`needs_extra`; if one is
not installed, the import raises :class:`MissingExtraError`, whose one line names the
``pip install`` to run (the command line prints it and exits non-zero, like any error a user can
cause).
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

from ..errors import LfdTrackError

EXTRAS: dict[str, tuple[str, tuple[str, ...]]] = {
    "web": ("the teaching station (lfd-track teach)", ("starlette", "uvicorn", "websockets")),
    "hardware": ("the serial link to the robot", ("serial",)),
    "video": ("writing videos", ("imageio_ffmpeg",)),
    "cmaes": ("the CMA-ES learner", ("cma",)),
    "cluster": ("studies on Ray (--executor ray)", ("ray",)),
    "play": (
        'the window of render_mode="human" and gymnasium.utils.play.play',
        ("pygame",),
    ),
    "minari": ("Minari datasets (export minari, evolve --minari)", ("minari", "h5py", "PIL")),
}
"""Extra name -> (what needs it, the top-level modules it provides)."""


class MissingExtraError(LfdTrackError, ImportError):
    """An optional feature was used without its extra installed."""


def install_line(extra: str) -> str:
    """The one line naming what is missing and the ``pip install`` that provides it."""
    feature, _ = EXTRAS[extra]
    return f"{feature} needs the {extra} extra: pip install 'lfd-track[{extra}]'"


@contextmanager
def needs_extra(extra: str) -> Iterator[None]:
    """Turn a missing module of ``extra`` imported inside the block into a MissingExtraError.

    Only the extra's own top-level modules count: an import error from inside an installed
    package (a broken install) propagates as it is.
    """
    _, modules = EXTRAS[extra]
    try:
        yield
    except ImportError as exc:
        missing = (exc.name or "").split(".")[0]
        if missing not in modules:
            raise
        raise MissingExtraError(install_line(extra)) from None
