"""Reading ``.lfdemo`` files: every schema (1-4), with the road library replayed from its log.

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
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import FileFormatError
from ..policy.memory import MemoryConfig
from ..utils.files import NonFiniteNumber, read_regular_file, reject_constant
from ..vision.road_library import RoadLibrary
from .checks import (
    MAX_MEMORY_INPUTS,
    _histogram_problem,
    _memory_problem,
    _pose_problem,
    _road_value_problem,
)
from .model import _DERIVED_KEYS, Demonstration, _counts
from .records import (
    _BAD_MAGIC,
    _CASE_FIXED,
    _CASE_FIXED_V1,
    _FRAME,
    _INDEX,
    _KIND_CASE,
    _KIND_FOOTER,
    _KIND_HEADER,
    _KIND_LEARNED,
    _KIND_SELECTED,
    _LEARNED_FIXED,
    _MAGIC,
    _MAX_JSON_BYTES,
    _MAX_MODELS,
    _SELECTED_FIXED,
    FORMAT_NAME,
    MAX_FILE_BYTES,
    MAX_ZERO_TAIL_BYTES,
    N_CHANNELS,
    N_VALUES,
    READABLE_SCHEMAS,
    SCHEMA_INDEXED,
    SCHEMA_WITH_MEMORY,
    SOURCES,
    _crc_ok,
    _max_case_length,
)


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


def _parse_json(path: Path, payload: memoryview, what: str) -> dict[str, Any]:
    try:
        obj = json.loads(bytes(payload).decode("utf-8"), parse_constant=reject_constant)
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise _fail(path, f"{what} is not valid JSON: {exc}") from None
    except NonFiniteNumber as exc:
        raise _fail(path, f"{what}: non-finite number {exc} is not allowed") from None
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
    arrays: dict[str, np.ndarray] = {
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


def load_for_learning(path: str | Path) -> tuple[Demonstration, RoadLibrary, MemoryConfig | None]:
    """A demonstration to learn from, its road library and its memory settings, with the checks
    every command that learns from a file makes: cases, a stored and non-empty road library,
    readable memory settings. Raises LfdTrackError (one line naming the file) otherwise."""
    from ..errors import LfdTrackError
    from ..utils.outputs import shown_path

    demo = load_demonstration(path)
    name = shown_path(path)
    if demo.n_cases == 0:
        raise LfdTrackError(f"{name}: the demonstration holds no cases")
    if not isinstance(demo.metadata.get("road_library"), dict):
        raise LfdTrackError(
            f"{name}: no road library stored (an interrupted recording without a"
            " library log, written by an older lfd-track: record it again)"
        )
    try:
        library = demo.road_library()
        memory = demo.memory_settings()
    except ValueError as exc:
        raise LfdTrackError(f"{name}: {exc}") from None
    if library.n_models == 0:
        raise LfdTrackError(
            f"{name}: its road library is empty (no frame was learned while"
            " recording), so a controller could not see the road"
        )
    return demo, library, memory
