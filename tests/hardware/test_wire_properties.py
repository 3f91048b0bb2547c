"""Property-based tests of the wire codec, and of the firmware against it (hypothesis).

The host codec's documented contract: ``encode_frame`` returns a frame that decodes back to what
was encoded, or raises ``ValueError`` (and nothing else) for anything that is not a valid frame;
``decode_line`` and ``FrameParser.feed`` never raise, and return either a ``Frame`` that is a
faithful reading of the line or a ``FrameError`` with one of ``wire.REASONS``. The last test
sends random and mutated lines to the real firmware in simavr and checks that board and host
reject exactly the same lines for the same reason.

``pytest --hypothesis-show-statistics`` prints how many inputs each test tried and, through
``event()``, how they were classified (accepted, or rejected with which reason).
"""

from __future__ import annotations

import string
from typing import TYPE_CHECKING

import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from lfd_track.hardware import wire
from lfd_track.hardware.wire import (
    MAX_LINE_BYTES,
    Frame,
    FrameError,
    FrameParser,
    decode_line,
    encode_frame,
)

if TYPE_CHECKING:
    from conftest import BoardLink  # the fixture's type, defined in tests/hardware/conftest.py

NOT_FRAMING = [b for b in range(256) if b not in b"$\n\r"]  # bytes that do not end a line
ARG_ALPHABET = "".join(c for c in string.printable if c not in ",*$\r\n\t\x0b\x0c")
letters = st.sampled_from(string.ascii_letters)
seqs = st.integers(0, wire.SEQ_MODULO - 1)
args_lists = st.lists(st.text(ARG_ALPHABET, min_size=1, max_size=8), max_size=4)


def _fits(frame_type: str, seq: int, args: list[str]) -> bool:
    body = ",".join([frame_type, str(seq), *args])
    return len(body) + 6 <= MAX_LINE_BYTES  # '$', '*' and 4 CRC digits


@settings(max_examples=500, deadline=None)
@given(letters, seqs, args_lists)
def test_every_valid_frame_round_trips(frame_type: str, seq: int, args: list[str]) -> None:
    if not _fits(frame_type, seq, args):
        event("too long: ValueError")
        with pytest.raises(ValueError, match="longer"):
            encode_frame(frame_type, seq, *args)
        return
    event("encoded")
    frame = Frame(frame_type, seq, tuple(args))
    line_bytes = encode_frame(frame_type, seq, *args)
    assert (
        line_bytes.endswith(b"\n")
        and line_bytes.count(b"\n") == 1
        and len(line_bytes) <= MAX_LINE_BYTES + 1
    )
    assert decode_line(line_bytes[:-1]) == frame
    assert decode_line(line_bytes[:-1] + b"\r") == frame
    assert FrameParser().feed(line_bytes) == [frame]
    # Any split into chunks gives the same frame.
    parser = FrameParser()
    assert [item for byte in line_bytes for item in parser.feed(bytes([byte]))] == [frame]


anything = st.one_of(
    st.text(max_size=4),
    st.integers(),
    st.floats(allow_nan=True),
    st.booleans(),
    st.none(),
    st.binary(max_size=4),
)


@settings(max_examples=500, deadline=None)
@given(anything, anything, st.lists(anything, max_size=3))
def test_encode_returns_a_decodable_frame_or_raises_value_error(
    frame_type: object, seq: object, args: list[object]
) -> None:
    try:
        line_bytes = encode_frame(frame_type, seq, *args)  # type: ignore[arg-type]
    except ValueError:
        event("rejected with ValueError")
        return
    event("encoded")
    decoded = decode_line(line_bytes[:-1])
    assert decoded == Frame(str(frame_type), int(seq), tuple(str(a) for a in args))  # type: ignore[call-overload]


def _check_decoded(line: bytes) -> Frame | FrameError:
    result = decode_line(line)
    if isinstance(result, FrameError):
        assert result.reason in wire.REASONS
        event(f"rejected: {result.reason}")
        return result
    # Accepted: the line is '$', the fields, '*', then the fields' CRC as 4 hex digits.
    event("accepted")
    stripped = line.rstrip(b"\r")
    body, crc = stripped[1:].split(b"*")
    assert stripped[:1] == b"$" and len(stripped) <= MAX_LINE_BYTES
    assert len(crc) == 4 and all(c in b"0123456789abcdefABCDEF" for c in crc)
    assert int(crc, 16) == wire.crc16(body)
    fields = body.decode("ascii").split(",")
    assert (result.type, result.args) == (fields[0], tuple(fields[2:]))
    assert result.seq == int(fields[1]) and fields[1].isdigit()
    return result


@settings(max_examples=1000, deadline=None)
@given(st.binary(max_size=40))
def test_any_bytes_decode_to_a_frame_or_a_documented_reason(line: bytes) -> None:
    _check_decoded(line)
    _check_decoded(b"$" + line)


@st.composite
def mutated_lines(draw: st.DrawFn) -> tuple[bytes, bytes]:
    """A valid frame line (no newline) and a mutation of it: replaced, inserted, deleted bytes."""
    frame_type = draw(st.sampled_from("DHECTVQ"))
    seq = draw(seqs)
    args = draw(st.lists(st.sampled_from(["F", "L", "R", "S", "300", "2000", "x"]), max_size=2))
    line = bytearray(encode_frame(frame_type, seq, *args)[:-1])
    original = bytes(line)
    for _ in range(draw(st.integers(1, 3))):
        op = draw(st.sampled_from(["replace", "insert", "delete", "flip"]))
        at = draw(st.integers(0, max(len(line) - 1, 0)))
        byte = draw(st.sampled_from(NOT_FRAMING))
        if op == "replace" and line:
            line[at] = byte
        elif op == "insert":
            line.insert(at, byte)
        elif op == "delete" and len(line) > 1:
            del line[at]
        elif op == "flip" and line:
            flipped = line[at] ^ (1 << draw(st.integers(0, 7)))
            if flipped not in b"$\n\r":
                line[at] = flipped
    return original, bytes(line)


@settings(max_examples=600, deadline=None)
@given(mutated_lines())
def test_mutated_lines_are_rejected_cleanly(lines: tuple[bytes, bytes]) -> None:
    original, mutated = lines
    result = _check_decoded(mutated)
    if isinstance(result, Frame) and mutated != original:
        # Only a change the checksum cannot see gets through: the case of a CRC digit.
        same_but_case = mutated.split(b"*")[0] == original.split(b"*")[0]
        if not same_but_case:
            event("mutation accepted (CRC-16 collision)")


@settings(max_examples=600, deadline=None)
@given(st.sampled_from("DHECTVQ"), seqs, st.integers(0, 15), st.integers(0, 255))
def test_every_single_byte_change_is_caught(
    frame_type: str, seq: int, position: int, value: int
) -> None:
    line = bytearray(encode_frame(frame_type, seq)[:-1])
    position %= len(line)
    if line[position] == value or value in b"\r":
        return
    is_crc_digit = position >= len(line) - 4
    old = line[position]
    line[position] = value
    result = _check_decoded(bytes(line))
    if isinstance(result, Frame):
        # CRC-16 catches every error burst up to 16 bits, so only the hex digits' case may vary.
        assert is_crc_digit and chr(value).lower() == chr(old).lower(), (bytes(line), result)


@settings(max_examples=300, deadline=None)
@given(st.sampled_from("DHECTV"), seqs, st.sampled_from([b" ", b"+", b"_"]), st.integers(1, 3))
def test_only_hex_digits_spell_the_crc(frame_type: str, seq: int, pad: bytes, at: int) -> None:
    """Python's int(x, 16) also reads " ABC", "+ABC" and "A_BC"; the firmware does not."""
    line_bytes = encode_frame(frame_type, seq)[:-1]
    head, crc = line_bytes[:-4], line_bytes[-4:]
    if pad == b"_":
        spelled = crc[1:at] + pad + crc[at:] if crc[:1] == b"0" else crc[:at] + pad + crc[at + 1 :]
    else:
        spelled = pad + crc[1:] if crc[:1] == b"0" else pad + crc[1:]
    line = head + spelled
    event("zero-led CRC (int() would accept)" if crc[:1] == b"0" else "other CRC")
    assert decode_line(line) == FrameError(wire.REASON_FRAME, line)


# --- the firmware against the host codec -------------------------------------------------------


@pytest.mark.simavr
@settings(
    max_examples=60,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(
    st.one_of(
        # One line as the board sees it: a '$' starts it (without one it is noise, ignored by
        # both), and no other '$' (which would start a new line, as in FrameParser).
        mutated_lines().map(lambda pair: b"$" + pair[1].replace(b"$", b"")),
        mutated_lines().map(lambda pair: pair[0]),  # unmutated: both accept
        st.binary(max_size=34).map(
            lambda b: b"$" + b.replace(b"$", b"").replace(b"\n", b"").replace(b"\r", b"")
        ),
    )
)
def test_the_firmware_rejects_exactly_what_the_host_codec_rejects(
    board_link: BoardLink, line: bytes
) -> None:
    expected = decode_line(line)
    board_link.write(line + b"\n")
    reply, _ = board_link.wait_for(lambda f: f.type in (wire.ACK, wire.NAK))
    if isinstance(expected, FrameError):
        event(f"both rejected: {expected.reason}")
        assert reply.type == wire.NAK and reply.args == (expected.reason,), (line, reply)
    else:
        event(f"host accepted; board {reply.type} {reply.args[0]}")
        assert reply.seq == expected.seq, (line, reply)
        assert reply.type == wire.ACK or reply.args[0] in (
            wire.REASON_ARG,
            wire.REASON_TYPE,
            wire.REASON_ESTOP,
        ), (line, reply)
