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


class CalibrationFailed(LfdTrackError):
    """A robot calibration that cannot give a trustworthy forward step and pivot (frames too
    uniform to match, estimates too scattered, a robot that does not move or stopped); one line
    says why, and nothing is written (:mod:`lfd_track.hardware.calibrate`)."""


class DemonstrationUnfinished(RuntimeError):
    """A demonstration or teaching loop that did not finish within its command budget (the
    human's ``max_commands``): the teacher got lost, nothing is wrong with the code.

    A benchmark records the repetition it ends as failed and carries on with the others
    (:mod:`lfd_track.benchmark.runner`); any other exception is a fault and propagates.
    ``counts`` is what the loop counted when it gave up (a
    :class:`~lfd_track.teaching.loop.LoopCounts`), None when unknown.
    """

    def __init__(self, message: str, counts: object = None) -> None:
        super().__init__(message)
        self.counts = counts

    def __reduce__(self) -> tuple[object, ...]:  # picklable with its counts (worker processes)
        return (type(self), (str(self), self.counts))


def first_line(exc: BaseException) -> str:
    """The first line of ``exc``'s message (its type's name when it has none): what a one-line
    error shows."""
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__
