"""Demonstration datasets on disk: an append-only, crash-safe record log (``.lfdemo``).

A demonstration is the sequence of *cases* a demonstrator recorded: the command it gave, the 40
road values computed at that moment with the record-time library, and the 40 x 5 x bins region
histograms those values came from (kept so the values can be recomputed with another library).
Each case also says where it came from: ``source`` is ``"demonstration"`` (the human drove) or
``"correction"`` (a human command that took control back from the policy, or an intervention
during an autonomous run), and ``round`` is 0 for the initial demonstration and r for the r-th
round of autonomous runs with interventions.

File layout (all integers little-endian)::

    magic      8 bytes  b"\\x89LFDEMO\\n"   (binary-safe, catches text-mode transfers)
    record*    kind u8 | length u32 | crc32 u32 | payload[length]

The CRC-32 covers kind, length and payload. From schema 4 on, every record after the header
starts its payload with its index ``u32`` (1 for the first record after the header, counting
every kind), so a record out of order, repeated or missing is refused; the layouts below follow
the index. Records, in order:

- ``H`` header, once, first: UTF-8 JSON ``{"format", "schema", "bins", "n_values", "n_channels",
  "metadata", "initial_road_library"}``; the last is the library snapshot when recording started
  (null when the writer was given no library to log).
- ``C`` case, one per ``append``: ``step i64 | command u8 | learned u8 | source u8 | round u32 |
  phase_len u16 | x, y, theta, progress_m f64 | phase utf-8 | road_values 40 f64 |
  memory n_memory f64 | histograms 40*5*bins f32``. ``source`` is an index into
  :data:`SOURCES`; ``memory`` holds the policy's memory inputs at that moment
  (:mod:`lfd_track.teaching.memory`), present from schema 3 on (the header's ``n_memory``).
- ``L`` library learned (only with a logged library): ``joined_type i16 | evicted_type i16 |
  evicted_example i16 | model 5*bins f32``; -1 means none (a new type; nothing evicted).
- ``S`` library selections (only with a logged library): ``n_models u16 | counts u8[n_models]``,
  the regions of one road-value frame that selected each model (they sum to 40).
- ``F`` footer, once, last, written by ``close``: UTF-8 JSON of the final metadata (the
  record-time road library snapshot, counts).

The ``L`` and ``S`` records are written as the road library changes, so an interrupted recording
still carries its library: replaying them onto ``initial_road_library`` rebuilds the library as it
was after the last intact record. A complete file's replayed library must equal the footer's
snapshot (checked at load); a partial file's replayed snapshot becomes its ``"road_library"``.

Schema 1 files (no source, round or library log) still load: every case is a ``"demonstration"``
of round 0. A recording without memory inputs is written as schema 2 (as before memory existed);
one with memory inputs as schema 3, whose header adds ``n_memory`` and whose cases carry them.
Every recording is now written as schema 4: the schema 3 layout with record indexes, its header
always saying ``n_memory`` (0 without memory). Schemas 1-3 still load exactly as before.

Why a log rather than ``.npz``: each case is one ``write`` of one record on an unbuffered file
(and by default ``fsync``-ed), so a killed recorder loses at most the case being written, and
appending stays O(1) per case where rewriting an archive per case would be O(N^2).

Loading reads records until end of file. A record cut short at the end of the file, or a
complete last record whose CRC fails (a filesystem may extend a file before the data lands: the
bytes that never landed read as zeros), is a *torn tail*: it is dropped and reported (``metadata["complete"] = False``,
``metadata["torn_tail_bytes"]``). A file without a footer is likewise ``complete = False`` but every
case in it is returned. A footer is never taken for a torn tail when all of its JSON is there (JSON
holds no zero byte) but its CRC or its length is wrong: that is corruption. A zero tail longer
than :data:`MAX_ZERO_TAIL_BYTES` is corruption too, refused from the file's last bytes before it
is read whole. Anything else — bad magic, unknown schema, a truncated or corrupt header,
a corrupt record with data after it, a length no record of its kind can have, data after the
footer, values out of range — raises :class:`lfd_track.errors.FileFormatError` with one line
naming the file and the problem. Only regular files up to :data:`MAX_FILE_BYTES` are read.

Physically possible values only: road values in [-1, 1], histogram values in [0, 1], steps >= 0,
poses and progress finite (or all NaN when unknown) and within ``MAX_POSITION_M``.

JSON metadata must be JSON-friendly (no NaN); tuples come back as lists.
"""

from __future__ import annotations

import json
import math
import os
import stat
import struct
import zlib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..atomic import atomic_write_bytes
from ..commands import Command
from ..errors import FileFormatError
from ..files import read_regular_file
from ..outputs import refuse_unsafe_output
from ..teaching.memory import MemoryConfig
from ..vision.road_library import LibraryChange, LibraryLearned, RoadLibrary

SCHEMA_VERSION = 4
"""Version of the record layout written now: every record after the header carries its index."""
SCHEMA_WITH_MEMORY = 3
"""The first version whose header may declare memory inputs (``n_memory``)."""
SCHEMA_INDEXED = 4
"""The first version whose records carry their index (1 for the first record after the header)."""
READABLE_SCHEMAS = (1, 2, 3, 4)
"""Schema versions this version of lfd-track loads."""
SOURCES = ("demonstration", "correction")
"""Case sources; a case stores the index into this tuple."""
MAX_ROUND = 2**32 - 1
MAX_FILE_BYTES = 1 << 32
"""Largest demonstration file read (4 GiB; a 1000-case recording at 32 bins is about 26 MB)."""
MAX_POSITION_M = 1e4
"""Largest |x|, |y| [m] and |progress| [m] a case may hold (tracks are far smaller)."""
FILE_EXTENSION = ".lfdemo"
FORMAT_NAME = "lfd-track demonstration"
N_VALUES = 40  # 8 x 5 image regions
N_CHANNELS = 5  # R, G, B, H, S histograms per region
DEFAULT_BINS = 32
MAX_MEMORY_INPUTS = 16
"""Most memory inputs a case may carry."""
MAX_ZERO_TAIL_BYTES = 1 << 24
"""Longest run of zero bytes at the end of a file taken as writes that never landed (16 MiB:
far more than the records written between two fsyncs); a longer one is corruption."""

_MAGIC = b"\x89LFDEMO\n"
_BAD_MAGIC = f"not a demonstration file (bad magic; expected a {FILE_EXTENSION} log)"
_FRAME = struct.Struct("<BII")  # kind, payload length, crc32
_INDEX = struct.Struct("<I")  # schema 4: a record's index, first in its payload
_CASE_FIXED_V1 = struct.Struct("<qBBH4d")  # step, command, learned, phase length, x, y, theta, s
# step, command, learned, source, round, phase length, x, y, theta, s
_CASE_FIXED = struct.Struct("<qBBBIH4d")
_LEARNED_FIXED = struct.Struct("<hhh")  # joined type, evicted type, evicted example (-1: none)
_SELECTED_FIXED = struct.Struct("<H")  # number of models
_KIND_HEADER = ord("H")
_KIND_CASE = ord("C")
_KIND_LEARNED = ord("L")
_KIND_SELECTED = ord("S")
_KIND_FOOTER = ord("F")
_MAX_MODELS = 10_000  # a library logged here has fewer models (u16 count)
_MAX_JSON_BYTES = 1 << 28  # generous bound for header/footer (a road library is ~1 MB of JSON)
_MAX_PHASE_BYTES = 255
_VALUE_TOLERANCE = 1e-6  # road values are correlations; allow float rounding past +-1
# Keys the loader derives; stored metadata never overrides them.
_DERIVED_KEYS = (
    "complete",
    "n_cases",
    "counts",
    "torn_tail_bytes",
    "schema_version",
    "bins",
    "library_log",
)


@dataclass(frozen=True, eq=False)
class Demonstration:
    """A loaded demonstration; arrays are read-only, one row per recorded case."""

    commands: np.ndarray
    """(N,) int8 — 0 forward, 1 left, 2 right."""
    road_values: np.ndarray
    """(N, 40) float64 — record-time road values, row-major from the top-left region."""
    histograms: np.ndarray
    """(N, 40, 5, bins) float32 — region histograms (R, G, B, H, S) the values came from."""
    poses: np.ndarray
    """(N, 3) float64 — (x [m], y [m], theta [rad]) when known (simulation), else NaN."""
    progress_m: np.ndarray
    """(N,) float64 — progress along the driven centreline [m]; NaN on hardware."""
    phases: np.ndarray
    """(N,) str — phase label, e.g. "library_only", "drive", "turnaround"."""
    learned: np.ndarray
    """(N,) bool — whether the road library learned from this frame."""
    steps: np.ndarray
    """(N,) int64 — the recorder's step index of each case."""
    sources: np.ndarray
    """(N,) str — ``"demonstration"`` or ``"correction"`` (see :data:`SOURCES`)."""
    rounds: np.ndarray
    """(N,) int64 — 0 for the initial demonstration, r for the r-th round of interventions."""
    metadata: dict[str, Any] = field(default_factory=dict)
    """File-level metadata: header metadata, footer metadata and derived keys (see module doc)."""
    memory: np.ndarray | None = None
    """(N, m) float64 — the policy's memory inputs at each case (m = 0 without memory)."""

    def __post_init__(self) -> None:
        if self.memory is None:
            empty = np.zeros((self.commands.shape[0], 0), dtype=np.float64)
            empty.flags.writeable = False
            object.__setattr__(self, "memory", empty)

    @property
    def inputs(self) -> np.ndarray:
        """(N, 40 + m) float64 — what the policy read: road values, then memory inputs."""
        assert self.memory is not None
        if not self.memory.shape[1]:
            return self.road_values
        return np.hstack([self.road_values, self.memory])

    @property
    def n_cases(self) -> int:
        """Number of recorded cases."""
        return int(self.commands.shape[0])

    @property
    def bins(self) -> int:
        """Histogram bins per channel."""
        return int(self.histograms.shape[-1])

    @property
    def command_counts(self) -> dict[str, int]:
        """Cases per command, keyed by lower-case command name (forward, left, right)."""
        counts = np.bincount(self.commands.astype(np.int64), minlength=len(Command))
        return {c.name.lower(): int(counts[c]) for c in Command}

    def road_library(self) -> RoadLibrary:
        """The road library as it was when recording ended (the one to drive with).

        Raises ValueError if the file stores none (a recording that was interrupted) or a bad one.
        """
        data = self.metadata.get("road_library")
        if not isinstance(data, dict):
            raise ValueError("no road library stored (recording was interrupted?)")
        try:
            return RoadLibrary.from_dict(data)
        except (ValueError, KeyError, TypeError) as exc:
            raise ValueError(f"bad road library ({exc})") from None

    def memory_settings(self) -> MemoryConfig | None:
        """The memory settings the cases' memory inputs were recorded with (None: no memory).

        Raises ValueError if the stored settings are bad or do not fit the cases' memory inputs.
        """
        assert self.memory is not None
        n_memory = self.memory.shape[1]
        settings = self.metadata.get("memory")
        if settings is None and n_memory == 0:
            return None
        try:
            memory = MemoryConfig.from_dict(settings)
        except ValueError as exc:
            raise ValueError(f"bad memory settings ({exc})") from None
        if memory.n_inputs != n_memory:
            raise ValueError(
                f"memory settings '{memory.kind}' need {memory.n_inputs} memory inputs per case,"
                f" the cases hold {n_memory}"
            )
        return memory


# --------------------------------------------------------------------------- encoding


def _frame(kind: int, payload: bytes, index: int | None = None) -> bytes:
    """A record; with ``index`` (schema 4) the payload starts with it."""
    if index is not None:
        payload = _INDEX.pack(index) + payload
    head = struct.pack("<BI", kind, len(payload))
    crc = zlib.crc32(payload, zlib.crc32(head))
    return _FRAME.pack(kind, len(payload), crc) + payload


def _json_bytes(obj: Any, what: str) -> bytes:
    try:
        text = json.dumps(obj, allow_nan=False, sort_keys=True, separators=(",", ":"))
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{what} is not JSON-friendly: {exc}") from None
    return text.encode("utf-8")


def _header_record(
    metadata: Mapping[str, Any],
    bins: int,
    initial_library: dict[str, Any] | None = None,
    n_memory: int = 0,
) -> bytes:
    from .. import __version__

    meta = dict(metadata)
    meta.setdefault("created_by", f"lfd-track {__version__}")
    header = {
        "format": FORMAT_NAME,
        "schema": SCHEMA_VERSION,
        "bins": bins,
        "n_values": N_VALUES,
        "n_channels": N_CHANNELS,
        "metadata": meta,
        "initial_road_library": initial_library,
        "n_memory": n_memory,
    }
    return _frame(_KIND_HEADER, _json_bytes(header, "demonstration metadata"))


def _footer_record(
    final_metadata: Mapping[str, Any], counts: dict[str, int], n: int, index: int
) -> bytes:
    footer = dict(final_metadata)
    footer["n_cases"] = n
    footer["counts"] = counts
    return _frame(_KIND_FOOTER, _json_bytes(footer, "final metadata"), index)


def _case_record(
    bins: int,
    step: int,
    command: int,
    road_values: np.ndarray,
    histograms: np.ndarray,
    pose: Any,
    progress_m: float | None,
    phase: str,
    learned: bool,
    source: str = "demonstration",
    round_: int = 0,
    memory: Any = None,
    n_memory: int = 0,
    index: int = 0,
) -> bytes:
    """Validate one case and encode it as a ``C`` record numbered ``index`` (raises ValueError on
    bad input)."""
    if int(command) not in (0, 1, 2) or int(command) != command:
        raise ValueError(f"command must be 0, 1 or 2, got {command!r}")
    if source not in SOURCES:
        raise ValueError(f"source must be one of {', '.join(SOURCES)}, got {source!r}")
    if isinstance(round_, bool) or int(round_) != round_ or not 0 <= int(round_) <= MAX_ROUND:
        raise ValueError(f"round must be an integer in 0..{MAX_ROUND}, got {round_!r}")
    if int(step) != step or not 0 <= int(step) < 2**63:
        raise ValueError(f"step must be a non-negative integer, got {step!r}")
    values = np.asarray(road_values, dtype=np.float64)
    if values.shape != (N_VALUES,):
        raise ValueError(f"road_values must have shape ({N_VALUES},), got {values.shape}")
    problem = _road_value_problem(values)
    if problem:
        raise ValueError(problem)
    mem = np.zeros(0) if memory is None else np.asarray(memory, dtype=np.float64).reshape(-1)
    if mem.shape != (n_memory,):
        raise ValueError(f"memory must hold {n_memory} inputs for this file, got {mem.shape[0]}")
    problem = _memory_problem(mem)
    if problem:
        raise ValueError(problem)
    hists = np.asarray(histograms)
    if hists.shape != (N_VALUES, N_CHANNELS, bins):
        raise ValueError(
            f"region_histograms must have shape ({N_VALUES}, {N_CHANNELS}, {bins}), "
            f"got {hists.shape}"
        )
    hists = hists.astype("<f4", copy=False)
    problem = _histogram_problem(hists)
    if problem:
        raise ValueError(f"region_histograms {problem}")
    xyt = (math.nan,) * 3 if pose is None else tuple(float(v) for v in pose)
    if len(xyt) != 3:
        raise ValueError(f"pose must be (x, y, theta), got {pose!r}")
    s = math.nan if progress_m is None else float(progress_m)
    problem = _pose_problem(xyt, s)
    if problem:
        raise ValueError(problem)
    phase_bytes = str(phase).encode("utf-8")
    if not phase_bytes or len(phase_bytes) > _MAX_PHASE_BYTES:
        raise ValueError(f"phase label must be 1..{_MAX_PHASE_BYTES} UTF-8 bytes, got {phase!r}")
    fixed = _CASE_FIXED.pack(
        int(step),
        int(command),
        1 if learned else 0,
        SOURCES.index(source),
        int(round_),
        len(phase_bytes),
        *xyt,
        s,
    )
    payload = b"".join(
        (
            fixed,
            phase_bytes,
            values.astype("<f8", copy=False).tobytes(),
            mem.astype("<f8", copy=False).tobytes(),
            hists.tobytes(),
        )
    )
    return _frame(_KIND_CASE, payload, index)


def _road_value_problem(values: np.ndarray) -> str:
    if not np.isfinite(values).all():
        return "road values contain NaN or infinity"
    worst = float(np.max(np.abs(values))) if values.size else 0.0
    if worst > 1.0 + _VALUE_TOLERANCE:
        return f"road value {worst:.6g} outside [-1, 1]"
    return ""


def _unit_interval_problem(a: np.ndarray, not_finite: str, outside: str) -> str:
    """``not_finite`` or ``outside`` when ``a`` has non-finite values or values outside [0, 1]."""
    if not np.isfinite(a).all():
        return not_finite
    if a.size and (a.min() < 0.0 or a.max() > 1.0):
        return outside
    return ""


def _memory_problem(memory: np.ndarray) -> str:
    return _unit_interval_problem(
        memory, "memory inputs contain NaN or infinity", "memory inputs must lie in [0, 1]"
    )


def _histogram_problem(hists: np.ndarray) -> str:
    return _unit_interval_problem(
        hists, "contain NaN or infinity", "values must lie in [0, 1] (normalised histograms)"
    )


def _pose_problem(xyt: tuple[float, ...], progress_m: float) -> str:
    unknown = [math.isnan(v) for v in xyt]
    if any(unknown) and not all(unknown):
        return f"pose must be three finite numbers or unknown (all NaN), got {xyt}"
    if not all(unknown):
        if not all(math.isfinite(v) for v in xyt):
            return f"pose must be three finite numbers or unknown (all NaN), got {xyt}"
        if max(abs(xyt[0]), abs(xyt[1])) > MAX_POSITION_M:
            return f"pose {xyt[:2]} is more than {MAX_POSITION_M:g} m from the origin"
        if abs(xyt[2]) > 1e6:
            return f"pose heading {xyt[2]} rad is not plausible"
    if not math.isnan(progress_m) and not abs(progress_m) <= MAX_POSITION_M:
        return f"progress {progress_m} m must be finite and within {MAX_POSITION_M:g} m"
    return ""


def _max_case_length(bins: int, n_memory: int = 0) -> int:
    values = 8 * (N_VALUES + n_memory)
    return _CASE_FIXED.size + _MAX_PHASE_BYTES + values + 4 * N_VALUES * N_CHANNELS * bins


def _learned_record(change: LibraryLearned, index: int) -> bytes:
    out = change.outcome
    joined = -1 if out.new_type else out.type_index
    fixed = _LEARNED_FIXED.pack(
        joined,
        -1 if out.evicted_type is None else out.evicted_type,
        -1 if out.evicted_example is None else out.evicted_example,
    )
    return _frame(_KIND_LEARNED, fixed + np.asarray(change.model, dtype="<f4").tobytes(), index)


def _selected_record(per_model: np.ndarray, index: int) -> bytes:
    counts = np.asarray(per_model)
    if counts.size > _MAX_MODELS:
        raise ValueError(f"a logged road library holds at most {_MAX_MODELS} models")
    return _frame(
        _KIND_SELECTED,
        _SELECTED_FIXED.pack(counts.size) + counts.astype(np.uint8).tobytes(),
        index,
    )


def _counts(commands: list[int] | np.ndarray) -> dict[str, int]:
    counts = np.bincount(np.asarray(commands, dtype=np.int64), minlength=len(Command))
    return {c.name.lower(): int(counts[c]) for c in Command}


def _check_n_memory(n_memory: int) -> int:
    if isinstance(n_memory, bool) or int(n_memory) != n_memory:
        raise ValueError(f"n_memory must be an integer, got {n_memory!r}")
    if not 0 <= int(n_memory) <= MAX_MEMORY_INPUTS:
        raise ValueError(f"n_memory must be in 0..{MAX_MEMORY_INPUTS}, got {n_memory}")
    return int(n_memory)


def _check_bins(bins: int) -> int:
    if isinstance(bins, bool) or int(bins) != bins or not 1 <= int(bins) <= 256:
        raise ValueError(f"bins must be an integer in 1..256, got {bins!r}")
    return int(bins)


# --------------------------------------------------------------------------- writing


def _open_recording(path: Path, overwrite: bool) -> Any:
    """``path`` opened for writing, unbuffered: a new file, or with ``overwrite`` an existing
    regular file emptied. Nothing but a regular file is opened (not through a symbolic link, nor
    a FIFO or a device that appeared since :func:`refuse_unsafe_output` looked)."""
    if not overwrite:
        return open(path, "xb", buffering=0)  # noqa: SIM115 - exclusive: never an existing file
    flags = os.O_WRONLY | os.O_CREAT | getattr(os, "O_CLOEXEC", 0)
    flags |= getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0)
    fd = os.open(path, flags, 0o666)
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            refuse_unsafe_output(path)
            raise FileFormatError(path, "not a regular file; an output only replaces one")
        os.set_blocking(fd, True)
        os.ftruncate(fd, 0)
    except BaseException:
        os.close(fd)
        raise
    return open(fd, "wb", buffering=0)  # noqa: SIM115


class DemonstrationWriter:
    """Record a demonstration case by case into a crash-safe ``.lfdemo`` log.

    Use as a context manager. Leaving the ``with`` block normally writes the footer; leaving it
    through an exception closes the file without one, so it loads as ``complete = False`` with
    every case appended so far.

    Args:
        path: file to create.
        metadata: JSON-friendly file metadata (track name, seed, demonstrator config, ...).
        bins: histogram bins per channel.
        fsync: ``fsync`` after every case, so cases also survive a power cut (a killed process
            loses nothing already appended either way, because writes are unbuffered).
        overwrite: replace an existing file instead of refusing.
        library: road library to log: its state now goes in the header and every later change
            (learning step, counter update) is appended as it happens, until the writer closes.
            Its ``bins`` must equal ``bins``.
        n_memory: memory inputs every case carries (0: none, a schema 2 file).
    """

    def __init__(
        self,
        path: str | Path,
        metadata: Mapping[str, Any],
        bins: int = DEFAULT_BINS,
        *,
        fsync: bool = True,
        overwrite: bool = False,
        library: RoadLibrary | None = None,
        n_memory: int = 0,
    ) -> None:
        self.path = Path(path)
        self.bins = _check_bins(bins)
        self.n_memory = _check_n_memory(n_memory)
        self._fsync = fsync
        self._commands: list[int] = []
        self._records = 0  # records written after the header (each carries its index)
        self._unsubscribe: Any = None
        if library is not None and library.bins != self.bins:
            raise ValueError(f"library has {library.bins} bins, the file {self.bins}")
        initial = None if library is None else library.to_dict()
        header = _header_record(metadata, self.bins, initial, self.n_memory)
        refuse_unsafe_output(self.path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        # Unbuffered: each record reaches the kernel in one write() call, so SIGKILL cannot
        # leave a record half in a user-space buffer.
        self._file = _open_recording(self.path, overwrite)
        try:
            self._write(_MAGIC + header)
            self._sync_directory()
        except BaseException:
            # Nothing was recorded (a full disk, an interrupt): leave no file that a later run
            # would have to be told to --force over.
            self._file.close()
            self.path.unlink(missing_ok=True)
            raise
        if library is not None:
            self._unsubscribe = library.subscribe(self._on_library_change)

    def _on_library_change(self, change: LibraryChange) -> None:
        if self._file.closed:
            return
        if isinstance(change, LibraryLearned):
            record = _learned_record(change, self._records + 1)
        else:
            record = _selected_record(change.per_model, self._records + 1)
        # No fsync of its own: the next case's fsync makes it durable (unbuffered writes already
        # survive a killed process).
        self._write_record(record, sync=False)

    @property
    def n_cases(self) -> int:
        """Cases appended so far."""
        return len(self._commands)

    @property
    def closed(self) -> bool:
        """True once ``close`` ran (or the file was abandoned after an error)."""
        return self._file.closed

    def append(
        self,
        command: int,
        road_values: np.ndarray,
        region_histograms: np.ndarray,
        *,
        pose: tuple[float, float, float] | np.ndarray | None = None,
        progress_m: float | None = None,
        phase: str = "drive",
        learned: bool = False,
        step: int | None = None,
        source: str = "demonstration",
        round: int = 0,  # the file's field name (shadows the builtin only in here)
        memory: np.ndarray | None = None,
    ) -> None:
        """Append one case and make it durable before returning.

        Args:
            command: 0 forward, 1 left, 2 right.
            road_values: (40,) float — values in [-1, 1], stored as float64.
            region_histograms: (40, 5, bins) float — stored as float32.
            pose: (x [m], y [m], theta [rad]) if known, else None (stored as NaN).
            progress_m: progress along the centreline [m], None if unknown (stored as NaN).
            phase: phase label, e.g. "library_only", "drive", "turnaround".
            learned: whether the road library learned from this frame.
            step: recorder step index (>= 0); defaults to the number of cases appended before.
            source: ``"demonstration"`` or ``"correction"`` (a human command that took control
                back from the policy, or an intervention during an autonomous run).
            round: 0 for the initial demonstration, r for the r-th round of autonomous runs.
            memory: the policy's memory inputs, (n_memory,) in [0, 1] (None when the file has
                none).
        """
        if self._file.closed:
            raise ValueError(f"{self.path}: demonstration writer is closed")
        index = len(self._commands) if step is None else int(step)
        record = _case_record(
            self.bins,
            index,
            command,
            road_values,
            region_histograms,
            pose,
            progress_m,
            phase,
            learned,
            source,
            round,
            memory,
            self.n_memory,
            self._records + 1,
        )
        self._write_record(record)
        self._commands.append(int(command))

    def close(self, final_metadata: Mapping[str, Any] | None = None) -> None:
        """Write the footer (final metadata, e.g. the road library snapshot, plus counts)."""
        if self._file.closed:
            return
        self._stop_logging()
        try:
            footer = _footer_record(
                final_metadata or {}, _counts(self._commands), self.n_cases, self._records + 1
            )
            self._write_record(footer)
        finally:
            self._file.close()

    def abandon(self) -> None:
        """Close without a footer: the file will load as an interrupted recording."""
        self._stop_logging()
        if not self._file.closed:
            self._file.close()

    def _stop_logging(self) -> None:
        if self._unsubscribe is not None:
            self._unsubscribe()
            self._unsubscribe = None

    def _write_record(self, record: bytes, *, sync: bool = True) -> None:
        """Write a record after the header (numbered ``self._records + 1``)."""
        self._write(record, sync=sync)
        self._records += 1

    def _write(self, data: bytes, *, sync: bool = True) -> None:
        view = memoryview(data)
        while view:  # a raw write may be partial (signals, pipes); finish the record
            written = self._file.write(view)
            view = view[written:]
        if self._fsync and sync:
            os.fsync(self._file.fileno())

    def _sync_directory(self) -> None:
        # Make the new directory entry durable too, or a power cut could lose the whole file.
        if not self._fsync or os.name != "posix":
            return
        fd = os.open(self.path.parent, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)

    def __enter__(self) -> DemonstrationWriter:
        return self

    def __exit__(self, exc_type: object, exc: object, tb: object) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abandon()


def save_demonstration(path: str | Path, demonstration: Demonstration) -> None:
    """Write ``demonstration`` as a complete ``.lfdemo`` file atomically (convert or copy)."""
    demo = demonstration
    bins = _check_bins(demo.bins)
    # Everything goes in the header; the loader merges header and footer, so the view is the same.
    meta = {k: v for k, v in demo.metadata.items() if k not in _DERIVED_KEYS}
    assert demo.memory is not None
    n_memory = _check_n_memory(demo.memory.shape[1])
    parts = [_MAGIC, _header_record(meta, bins, n_memory=n_memory)]
    for i in range(demo.n_cases):
        parts.append(
            _case_record(
                bins,
                int(demo.steps[i]),
                int(demo.commands[i]),
                demo.road_values[i],
                demo.histograms[i],
                demo.poses[i],
                float(demo.progress_m[i]),
                str(demo.phases[i]),
                bool(demo.learned[i]),
                str(demo.sources[i]),
                int(demo.rounds[i]),
                demo.memory[i],
                n_memory,
                i + 1,
            )
        )
    parts.append(_footer_record({}, _counts(demo.commands), demo.n_cases, demo.n_cases + 1))
    atomic_write_bytes(path, b"".join(parts))


# --------------------------------------------------------------------------- reading


def load_demonstration(path: str | Path) -> Demonstration:
    """Load a ``.lfdemo`` file, keeping every intact case of an interrupted recording.

    The returned metadata is the header metadata updated with the footer's (e.g. the
    ``"road_library"`` snapshot passed to ``close``), plus derived keys ``schema_version``,
    ``bins``, ``n_cases``, ``counts``, ``complete``, ``torn_tail_bytes`` and ``library_log``
    (whether the file logs its road library). An interrupted recording with a library log gets
    the replayed library as its ``"road_library"``.

    Raises:
        FileFormatError: one line naming the file and the problem.
    """
    path = Path(path)

    def check_magic(head: bytes) -> None:
        # A large file of another kind is refused before it is read whole.
        if len(head) == len(_MAGIC) and head != _MAGIC:
            raise _fail(path, _BAD_MAGIC)

    data = read_regular_file(
        path,
        MAX_FILE_BYTES,
        "demonstration",
        check_head=check_magic,
        head_bytes=len(_MAGIC),
        max_zero_tail=MAX_ZERO_TAIL_BYTES,
    )
    return _parse(path, memoryview(data))


def _fail(path: Path, problem: str) -> FileFormatError:
    return FileFormatError(path, problem)


class _Replay:
    """Rebuilds the record-time road library from the header snapshot and the L/S records."""

    def __init__(self, path: Path, initial: Any, bins: int) -> None:
        self.path = path
        try:
            self.library = RoadLibrary.from_dict(initial)
        except (ValueError, TypeError, KeyError, OverflowError) as exc:
            raise _fail(path, f"initial road library: {exc}") from None
        if self.library.bins != bins:
            raise _fail(path, f"initial road library has {self.library.bins} bins, not {bins}")

    def learned(self, payload: memoryview, start: int) -> None:
        bins = self.library.bins
        if len(payload) != _LEARNED_FIXED.size + 4 * N_CHANNELS * bins:
            raise _fail(self.path, f"library record at byte {start} has the wrong length")
        joined, evicted_type, evicted_example = _LEARNED_FIXED.unpack_from(payload, 0)
        model = np.frombuffer(payload, "<f4", N_CHANNELS * bins, _LEARNED_FIXED.size)
        problem = _histogram_problem(model)
        if problem:
            raise _fail(self.path, f"library record at byte {start}: model {problem}")
        try:
            self.library.redo_learned(
                model.reshape(N_CHANNELS, bins),
                joined_type=None if joined < 0 else joined,
                evicted_type=None if evicted_type < 0 else evicted_type,
                evicted_example=None if evicted_example < 0 else evicted_example,
            )
        except ValueError as exc:
            raise _fail(
                self.path, f"library record at byte {start} does not apply: {exc}"
            ) from None

    def selected(self, payload: memoryview, start: int) -> None:
        if len(payload) < _SELECTED_FIXED.size:
            raise _fail(self.path, f"selection record at byte {start} is too short")
        (n,) = _SELECTED_FIXED.unpack_from(payload, 0)
        if len(payload) != _SELECTED_FIXED.size + n:
            raise _fail(self.path, f"selection record at byte {start} has the wrong length")
        counts = np.frombuffer(payload, np.uint8, n, _SELECTED_FIXED.size).astype(np.int64)
        try:
            self.library.redo_selected(counts)
        except ValueError as exc:
            raise _fail(
                self.path, f"selection record at byte {start} does not apply: {exc}"
            ) from None


def _parse(path: Path, data: memoryview) -> Demonstration:
    size = len(data)
    if size == 0:
        raise _fail(path, "empty file (the recording never wrote its header)")
    if size < len(_MAGIC) or bytes(data[: len(_MAGIC)]) != _MAGIC:
        if bytes(data[: len(_MAGIC)]) == _MAGIC[:size]:
            raise _fail(path, "truncated header")
        raise _fail(path, _BAD_MAGIC)
    offset = len(_MAGIC)

    # Header: must be whole and intact, or nothing in the file can be interpreted.
    if size - offset < _FRAME.size:
        raise _fail(path, "truncated header")
    kind, length, crc = _FRAME.unpack_from(data, offset)
    if kind != _KIND_HEADER:
        raise _fail(path, "first record is not a header")
    if length > _MAX_JSON_BYTES:
        raise _fail(path, f"header length {length} is not plausible (corrupt file)")
    end = offset + _FRAME.size + length
    if end > size:
        raise _fail(path, "truncated header")
    payload = data[offset + _FRAME.size : end]
    if not _crc_ok(kind, payload, crc):
        raise _fail(path, "header record is corrupt (CRC mismatch)")
    header = _parse_json(path, payload, "header")
    schema, bins, user_meta, n_memory = _check_header(path, header)
    replay = None
    if schema >= 2 and header.get("initial_road_library") is not None:
        replay = _Replay(path, header["initial_road_library"], bins)
    offset = end

    indexed = schema >= SCHEMA_INDEXED
    extra = _INDEX.size if indexed else 0
    max_case = _max_case_length(bins, n_memory)
    limits = {_KIND_CASE: max_case + extra, _KIND_FOOTER: _MAX_JSON_BYTES + extra}
    if replay is not None:
        limits[_KIND_LEARNED] = _LEARNED_FIXED.size + 4 * N_CHANNELS * bins + extra
        limits[_KIND_SELECTED] = _SELECTED_FIXED.size + _MAX_MODELS + extra
    cases: list[tuple[Any, ...]] = []
    footer: dict[str, Any] | None = None
    torn = 0
    records = 0  # records read after the header
    while offset < size:
        start = offset
        if footer is not None:
            raise _fail(path, f"data after the footer at byte {start}")
        if size - offset < _FRAME.size:
            torn = size - start
            break
        kind, length, crc = _FRAME.unpack_from(data, offset)
        limit = limits.get(kind)
        if limit is None or length > limit:
            if not np.frombuffer(data, np.uint8, size - start, start).any():
                # Zero fill a filesystem left past the last writes, if it is not too long.
                if size - start > MAX_ZERO_TAIL_BYTES:
                    raise _fail(
                        path,
                        f"{size - start} zero bytes from byte {start} to the end, more than"
                        " writes that never landed leave (corrupt file)",
                    )
                torn = size - start
                break
            if limit is None:
                raise _fail(path, f"unknown record kind {kind} at byte {start} (corrupt file)")
            raise _fail(path, f"record at byte {start} has impossible length {length} (corrupt)")
        end = offset + _FRAME.size + length
        if end > size:
            if kind == _KIND_FOOTER and _whole_json(data[offset + _FRAME.size + extra :]):
                raise _fail(path, f"footer at byte {start} has a wrong length (corrupt file)")
            torn = size - start
            break
        payload = data[offset + _FRAME.size : end]
        if not _crc_ok(kind, payload, crc):
            # A last record whose bytes never fully landed (they read as zeros) is a torn tail;
            # a footer all of whose JSON is there (JSON holds no zero byte) is damaged instead.
            landed = kind == _KIND_FOOTER and 0 not in bytes(payload[extra:])
            if end == size and not landed:
                torn = size - start
                break
            what = "footer" if kind == _KIND_FOOTER else "record"
            raise _fail(path, f"{what} at byte {start} is corrupt (CRC mismatch)")
        records += 1
        if indexed:
            if length < _INDEX.size:
                raise _fail(path, f"record at byte {start} is too short for its index (corrupt)")
            (index,) = _INDEX.unpack_from(payload, 0)
            if index != records:
                raise _fail(
                    path,
                    f"record at byte {start} is record {index}, expected record {records}:"
                    " records are missing, repeated or out of order (corrupt file)",
                )
            payload = payload[_INDEX.size :]
        if kind == _KIND_CASE:
            cases.append(_decode_case(path, payload, bins, len(cases), schema, n_memory))
        elif kind == _KIND_LEARNED:
            assert replay is not None
            replay.learned(payload, start)
        elif kind == _KIND_SELECTED:
            assert replay is not None
            replay.selected(payload, start)
        else:
            footer = _parse_json(path, payload, "footer")
        offset = end

    return _assemble(path, cases, bins, schema, user_meta, footer, torn, replay, n_memory)


def _whole_json(data: memoryview) -> bool:
    """Whether ``data`` is one whole JSON object (a footer cut short never is)."""
    if not data or 0 in bytes(data[:1]):
        return False
    try:
        return isinstance(json.loads(bytes(data).decode("utf-8")), dict)
    except (ValueError, RecursionError):
        return False


def _crc_ok(kind: int, payload: memoryview, crc: int) -> bool:
    head = struct.pack("<BI", kind, len(payload))
    return zlib.crc32(payload, zlib.crc32(head)) == crc


def _reject_constant(name: str) -> Any:
    raise ValueError(f"non-finite number {name} is not allowed")


def _parse_json(path: Path, payload: memoryview, what: str) -> dict[str, Any]:
    try:
        obj = json.loads(bytes(payload).decode("utf-8"), parse_constant=_reject_constant)
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise _fail(path, f"{what} is not valid JSON: {exc}") from None
    except RecursionError:
        raise _fail(path, f"{what} JSON is nested too deeply") from None
    except ValueError as exc:  # NaN/Infinity, or an integer with thousands of digits
        raise _fail(path, f"{what}: {str(exc).splitlines()[0]}") from None
    if not isinstance(obj, dict):
        raise _fail(path, f"{what} must be a JSON object")
    return obj


def _check_header(path: Path, header: dict[str, Any]) -> tuple[int, int, dict[str, Any], int]:
    if header.get("format") != FORMAT_NAME:
        raise _fail(path, f"header format is {header.get('format')!r}, expected {FORMAT_NAME!r}")
    schema = header.get("schema")
    if isinstance(schema, bool) or schema not in READABLE_SCHEMAS:
        readable = ", ".join(str(v) for v in READABLE_SCHEMAS)
        raise _fail(
            path, f"unsupported schema version {schema!r} (this lfd-track reads {readable})"
        )
    if header.get("n_values") != N_VALUES or header.get("n_channels") != N_CHANNELS:
        raise _fail(
            path,
            f"header declares {header.get('n_values')!r} values x {header.get('n_channels')!r} "
            f"channels, expected {N_VALUES} x {N_CHANNELS}",
        )
    bins = header.get("bins")
    if not isinstance(bins, int) or isinstance(bins, bool) or not 1 <= bins <= 256:
        raise _fail(path, f"header bins must be an integer in 1..256, got {bins!r}")
    meta = header.get("metadata")
    if not isinstance(meta, dict):
        raise _fail(path, "header metadata must be a JSON object")
    if schema < SCHEMA_WITH_MEMORY and "n_memory" in header:
        raise _fail(path, f"a schema {schema} header cannot declare n_memory (memory is schema 3)")
    n_memory = header.get("n_memory") if schema >= SCHEMA_WITH_MEMORY else 0
    # Schema 3 is the memory layout (at least one input); schema 4 says n_memory, 0 or more.
    fewest = 1 if schema == SCHEMA_WITH_MEMORY else 0
    if (
        not isinstance(n_memory, int)
        or isinstance(n_memory, bool)
        or not (schema < SCHEMA_WITH_MEMORY or fewest <= n_memory <= MAX_MEMORY_INPUTS)
    ):
        raise _fail(
            path,
            f"header n_memory must be an integer in {fewest}..{MAX_MEMORY_INPUTS},"
            f" got {n_memory!r}",
        )
    return schema, bins, meta, n_memory


def _decode_case(
    path: Path, payload: memoryview, bins: int, index: int, schema: int, n_memory: int = 0
) -> tuple[Any, ...]:
    where = f"case {index}"
    fixed = _CASE_FIXED if schema >= 2 else _CASE_FIXED_V1
    if len(payload) < fixed.size:
        raise _fail(path, f"{where}: record too short")
    if schema >= 2:
        step, command, learned, source, round_, phase_len, x, y, theta, s = fixed.unpack_from(
            payload, 0
        )
    else:
        step, command, learned, phase_len, x, y, theta, s = fixed.unpack_from(payload, 0)
        source, round_ = 0, 0
    expected = fixed.size + phase_len + 8 * (N_VALUES + n_memory) + 4 * N_VALUES * N_CHANNELS * bins
    if len(payload) != expected:
        raise _fail(
            path,
            f"{where}: record is {len(payload)} bytes, expected {expected} for {bins} bins"
            + (f" and {n_memory} memory inputs" if n_memory else ""),
        )
    if command not in (0, 1, 2):
        raise _fail(path, f"{where}: command {command} is not 0, 1 or 2")
    if learned not in (0, 1):
        raise _fail(path, f"{where}: learned flag {learned} is not 0 or 1")
    if source >= len(SOURCES):
        raise _fail(path, f"{where}: source code {source} is not one of 0..{len(SOURCES) - 1}")
    if step < 0:
        raise _fail(path, f"{where}: step {step} is negative")
    problem = _pose_problem((x, y, theta), s)
    if problem:
        raise _fail(path, f"{where}: {problem}")
    pos = fixed.size
    try:
        phase = bytes(payload[pos : pos + phase_len]).decode("utf-8")
    except UnicodeDecodeError:
        raise _fail(path, f"{where}: phase label is not UTF-8") from None
    pos += phase_len
    values = np.frombuffer(payload, dtype="<f8", count=N_VALUES, offset=pos)
    pos += 8 * N_VALUES
    memory = np.frombuffer(payload, dtype="<f8", count=n_memory, offset=pos)
    pos += 8 * n_memory
    hists = np.frombuffer(payload, dtype="<f4", count=N_VALUES * N_CHANNELS * bins, offset=pos)
    problem = _road_value_problem(values) or _memory_problem(memory)
    if problem:
        raise _fail(path, f"{where}: {problem}")
    problem = _histogram_problem(hists)
    if problem:
        raise _fail(path, f"{where}: region histograms {problem}")
    return (
        step,
        command,
        bool(learned),
        (x, y, theta),
        s,
        phase,
        values,
        hists,
        source,
        round_,
        memory,
    )


def _assemble(
    path: Path,
    cases: list[tuple[Any, ...]],
    bins: int,
    schema: int,
    user_meta: dict[str, Any],
    footer: dict[str, Any] | None,
    torn: int,
    replay: _Replay | None,
    n_memory: int = 0,
) -> Demonstration:
    n = len(cases)
    commands = np.array([c[1] for c in cases], dtype=np.int8)
    if footer is not None and footer.get("n_cases") != n:
        raise _fail(path, f"footer says {footer.get('n_cases')!r} cases but the file holds {n}")
    meta = {k: v for k, v in user_meta.items() if k not in _DERIVED_KEYS}
    if footer is not None:
        # Footer keys (e.g. the end-of-recording road library) join the header's; footer wins.
        meta.update((k, v) for k, v in footer.items() if k not in _DERIVED_KEYS)
    if replay is not None:
        replayed = replay.library.to_dict()
        stored = footer.get("road_library") if footer is not None else None
        if stored is None:
            meta["road_library"] = replayed
        elif stored != replayed:
            raise _fail(
                path, "the road-library log does not rebuild the footer's library (corrupt file)"
            )
    meta.update(
        schema_version=schema,
        bins=bins,
        n_cases=n,
        counts=_counts(commands),
        complete=footer is not None,
        torn_tail_bytes=torn,
        library_log=replay is not None,
    )
    arrays = {
        "commands": commands,
        "road_values": (
            np.stack([c[6] for c in cases]).astype(np.float64)
            if n
            else np.zeros((0, N_VALUES), np.float64)
        ),
        "histograms": (
            np.stack([c[7] for c in cases])
            .astype(np.float32)
            .reshape(n, N_VALUES, N_CHANNELS, bins)
            if n
            else np.zeros((0, N_VALUES, N_CHANNELS, bins), np.float32)
        ),
        "poses": np.array([c[3] for c in cases], dtype=np.float64).reshape(n, 3),
        "progress_m": np.array([c[4] for c in cases], dtype=np.float64),
        "phases": np.array([c[5] for c in cases], dtype=str),
        "learned": np.array([c[2] for c in cases], dtype=bool),
        "steps": np.array([c[0] for c in cases], dtype=np.int64),
        "sources": np.array([SOURCES[c[8]] for c in cases], dtype="<U13").reshape(n),
        "rounds": np.array([c[9] for c in cases], dtype=np.int64),
        "memory": (
            np.stack([c[10] for c in cases]).astype(np.float64)
            if n
            else np.zeros((0, n_memory), np.float64)
        ),
    }
    for arr in arrays.values():
        arr.flags.writeable = False
    return Demonstration(metadata=meta, **arrays)
