"""The ``.lfdemo`` record layout: constants, and encoding one record of each kind.

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
  (:mod:`lfd_track.policy.memory`), present from schema 3 on (the header's ``n_memory``).
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

JSON metadata must be JSON-friendly (no NaN); tuples come back as lists.
"""

from __future__ import annotations

import json
import math
import struct
import zlib
from collections.abc import Mapping
from typing import Any

import numpy as np

from ..vision.road_library import LibraryLearned
from .checks import (
    MAX_MEMORY_INPUTS,
    MAX_POSITION_M,
    _histogram_problem,
    _memory_problem,
    _pose_problem,
    _road_value_problem,
)

__all__ = ["MAX_MEMORY_INPUTS", "MAX_POSITION_M"]  # the value limits, defined with their checks

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
FILE_EXTENSION = ".lfdemo"
FORMAT_NAME = "lfd-track demonstration"
N_VALUES = 40  # 8 x 5 image regions
N_CHANNELS = 5  # R, G, B, H, S histograms per region
DEFAULT_BINS = 32
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


def _crc_ok(kind: int, payload: memoryview, crc: int) -> bool:
    head = struct.pack("<BI", kind, len(payload))
    return zlib.crc32(payload, zlib.crc32(head)) == crc
