"""Errors a user can cause. Each carries one line naming the file or thing and the problem."""

from __future__ import annotations


class LfdTrackError(Exception):
    """Base class for user-facing errors (bad files, bad flags, lost links)."""


class FileFormatError(LfdTrackError, ValueError):
    """A user-supplied file (track, preset, controller, demonstration) is malformed."""

    def __init__(self, path: object, problem: str) -> None:
        self.path = str(path)
        self.problem = problem
        super().__init__(f"{self.path}: {problem}")


def first_line(exc: BaseException) -> str:
    """The first line of ``exc``'s message (its type's name when it has none): what a one-line
    error shows."""
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__
