"""Saved cases an offline learner fits besides its own demonstration's (``extra_cases``).

A repetition's learner fits the cases of the one demonstration it records. With ``extra_cases``
(a study condition's key, :class:`~lfd_track.benchmark.config.BenchmarkConfig`) it fits them
followed by saved cases of other demonstrations: other rooms, other days, other people. The
human goal's round 41 (``benchmarks/experiments/human_goal/round41/``) measured it: each room's
demonstration fitted together with ten other rooms' demonstrations by the same human model.

The format: one ``.npz`` file per demonstration, with ``x`` (N, inputs) the policy's inputs of
each case as the learner fits them (mirror images included, if the learner learns from them) and
``a`` (N,) its command (0 forward, 1 left, 2 right); :func:`save_cases` writes one. ``extra_cases``
names such a file or a folder of them, read in the order of the files' names. Every file is
checked when a study file naming it is loaded, when the benchmark command starts and at the fit,
and a bad one is refused in one line naming the file and the problem
(:class:`~lfd_track.errors.FileFormatError`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..core.commands import Command
from ..errors import FileFormatError

SUFFIX = ".npz"
"""The suffix of a saved-cases file."""


def save_cases(path: str | Path, inputs: np.ndarray, commands: np.ndarray) -> Path:
    """Write one demonstration's cases (``inputs`` (N, k), ``commands`` (N,)) to ``path`` (its
    suffix made ``.npz``), in the format :func:`load_cases` reads; returns the path written."""
    out = Path(path).with_suffix(SUFFIX)
    x, a = _checked(out, np.asarray(inputs), np.asarray(commands))
    out.parent.mkdir(parents=True, exist_ok=True)
    np.savez(out, x=x, a=a)
    return out


def case_files(path: str | Path) -> list[Path]:
    """The saved-cases files ``path`` names: itself, or a folder's ``*.npz`` by name; a path
    that is neither, or a folder without any, is refused in one line."""
    p = Path(path)
    if p.is_dir():
        files = sorted(p.glob(f"*{SUFFIX}"))
        if not files:
            raise FileFormatError(p, f"no saved cases (*{SUFFIX}) in this folder")
        return files
    if not p.is_file():
        raise FileFormatError(p, "no such file or folder of saved cases")
    if p.suffix != SUFFIX:
        raise FileFormatError(p, f"saved cases are {SUFFIX} files")
    return [p]


def load_cases(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """Every case ``path`` names (:func:`case_files`), concatenated in the files' order:
    (inputs (N, k) float64, commands (N,) int64). A file that is not such cases, or whose
    inputs are not as many as the others', is refused in one line naming it."""
    xs: list[np.ndarray] = []
    commands: list[np.ndarray] = []
    for f in case_files(path):
        try:
            with np.load(f, allow_pickle=False) as data:
                if "x" not in data or "a" not in data:
                    raise FileFormatError(f, "saved cases need arrays 'x' and 'a'")
                x, a = _checked(f, data["x"], data["a"])
        except FileFormatError:
            raise
        except (OSError, ValueError) as exc:  # not an .npz archive, or an unreadable one
            raise FileFormatError(f, f"not a saved-cases file ({exc})") from None
        if xs and x.shape[1] != xs[0].shape[1]:
            raise FileFormatError(
                f, f"{x.shape[1]} inputs a case, where the files before have {xs[0].shape[1]}"
            )
        xs.append(x)
        commands.append(a)
    return np.concatenate(xs), np.concatenate(commands)


def with_extra_cases(
    path: str | Path, inputs: np.ndarray, commands: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """A learner's own cases followed by the saved cases ``path`` names; saved cases with
    another number of inputs than the learner's are refused in one line naming ``path``."""
    x, a = load_cases(path)
    if x.shape[1] != inputs.shape[1]:
        raise FileFormatError(
            path, f"saved cases have {x.shape[1]} inputs a case, the learner's {inputs.shape[1]}"
        )
    return (
        np.concatenate([np.asarray(inputs, dtype=np.float64), x]),
        np.concatenate([np.asarray(commands, dtype=np.int64), a]),
    )


def _checked(path: Path, x: np.ndarray, a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(x float64, a int64) if they are cases, else a one-line refusal naming ``path``."""
    if x.ndim != 2 or x.shape[0] == 0 or x.shape[1] == 0:
        raise FileFormatError(path, f"'x' must be (cases, inputs) with both > 0, got {x.shape}")
    if not np.issubdtype(x.dtype, np.number) or not np.all(np.isfinite(x)):
        raise FileFormatError(path, "'x' must hold finite numbers")
    if a.shape != (x.shape[0],):
        raise FileFormatError(
            path, f"'a' must hold one command a case: {x.shape[0]}, got {a.shape}"
        )
    if not np.issubdtype(a.dtype, np.integer) or a.min() < 0 or a.max() >= len(Command):
        raise FileFormatError(path, f"'a' must hold commands 0..{len(Command) - 1}")
    return np.asarray(x, dtype=np.float64), np.asarray(a, dtype=np.int64)
