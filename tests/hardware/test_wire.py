"""Wire codec: CRC, encoding, decoding, resynchronisation, bounds; fuzzed parser."""

from __future__ import annotations

import binascii

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from lfd_track.hardware import wire
from lfd_track.hardware.wire import (
    MAX_LINE_BYTES,
    Frame,
    FrameError,
    FrameParser,
    crc16,
    decode_line,
    encode_frame,
)


def test_crc_is_ccitt_false() -> None:
    assert crc16(b"123456789") == 0x29B1  # the CRC-16/CCITT-FALSE check value
    assert crc16(b"D,1,F") == binascii.crc_hqx(b"D,1,F", 0xFFFF)


@pytest.mark.parametrize(
    ("frame", "body"),
    [
        (Frame("D", 1, ("F",)), b"D,1,F"),
        (Frame("D", 65535, ("S",)), b"D,65535,S"),
        (Frame("H", 7), b"H,7"),
        (Frame("E", 8), b"E,8"),
        (Frame("C", 9), b"C,9"),
        (Frame("T", 10, ("300",)), b"T,10,300"),
        (Frame("A", 1, ("F", "0")), b"A,1,F,0"),
        (Frame("N", 2, ("ESTOP",)), b"N,2,ESTOP"),
        (Frame("B", 0, ("1.0",)), b"B,0,1.0"),
        (Frame("W", 0, ("S",)), b"W,0,S"),
    ],
)
def test_design_examples_round_trip(frame: Frame, body: bytes) -> None:
    wire = frame.encode()
    assert wire == b"$" + body + b"*" + b"%04X" % binascii.crc_hqx(body, 0xFFFF) + b"\n"
    assert decode_line(wire[:-1]) == frame
    assert decode_line(wire[:-1] + b"\r") == frame  # CRLF from a serial monitor
    assert FrameParser().feed(wire) == [frame]


def test_lower_case_crc_digits_are_accepted() -> None:
    wire = encode_frame("H", 3).rstrip(b"\n")
    assert decode_line(wire.lower().replace(b"$h", b"$H")) == Frame("H", 3)


@pytest.mark.parametrize(
    ("line", "reason"),
    [
        (b"$D,1,F*0000", wire.REASON_CRC),
        (b"$D,1,F", wire.REASON_FRAME),  # no CRC
        (b"$D,1,F*12", wire.REASON_FRAME),  # short CRC
        (b"$D,1,F*ZZZZ", wire.REASON_FRAME),
        (b"D,1,F*0000", wire.REASON_FRAME),  # no '$'
        (b"$D,1*2*3", wire.REASON_FRAME),
    ],
)
def test_bad_lines_are_rejected_with_a_reason(line: bytes, reason: str) -> None:
    result = decode_line(line)
    assert isinstance(result, FrameError) and result.reason == reason


def test_bad_fields_with_a_valid_crc_are_frame_errors() -> None:
    for body in (b"DD,1", b"D,x", b"D,65536", b"D", b"1,2"):
        line = b"$" + body + b"*" + b"%04X" % crc16(body)
        result = decode_line(line)
        assert isinstance(result, FrameError) and result.reason == wire.REASON_FRAME, body


def test_lines_over_31_bytes_are_rejected() -> None:
    body = b"T,1," + b"9" * 20
    line = b"$" + body + b"*" + b"%04X" % crc16(body)
    assert len(line) == 30
    assert isinstance(decode_line(line), Frame)
    long_body = b"T,1," + b"9" * 22
    long_line = b"$" + long_body + b"*" + b"%04X" % crc16(long_body)
    assert len(long_line) == MAX_LINE_BYTES + 1
    assert decode_line(long_line) == FrameError(wire.REASON_LONG, long_line)
    assert FrameParser().feed(long_line + b"\n")[0].reason == wire.REASON_LONG
    with pytest.raises(ValueError, match="longer"):
        encode_frame("T", 1, "9" * 22)


def test_encode_rejects_bad_input() -> None:
    for args in (("D", -1), ("D", 65536), ("DD", 1), ("1", 1)):
        with pytest.raises(ValueError):
            encode_frame(*args)
    for arg in ("", "a,b", "a*b", "$", "é"):
        with pytest.raises(ValueError):
            encode_frame("D", 1, arg)


def test_dollar_resynchronises() -> None:
    wire = encode_frame("H", 2)
    # A frame cut off by line noise, then a new '$': only the new frame counts.
    assert FrameParser().feed(b"junk\n$D,1,F*" + wire) == [Frame("H", 2)]
    assert FrameParser().feed(b"\x00\xff" + wire + b"tail") == [Frame("H", 2)]


def test_parser_accepts_any_chunking() -> None:
    wire = encode_frame("D", 1, "L") + b"noise" + encode_frame("A", 1, "L", "0")
    parser = FrameParser()
    frames = [item for byte in wire for item in parser.feed(bytes([byte]))]
    assert frames == [Frame("D", 1, ("L",)), Frame("A", 1, ("L", "0"))]


def test_overflow_is_reported_once_then_parsing_continues() -> None:
    parser = FrameParser()
    out = parser.feed(b"$" + b"x" * 500)
    assert out == [] and parser.buffered <= MAX_LINE_BYTES + 1
    out = parser.feed(b"more\n" + encode_frame("H", 4))
    assert [getattr(item, "reason", None) for item in out] == [wire.REASON_LONG, None]
    assert out[1] == Frame("H", 4)


@settings(max_examples=300, deadline=None)
@given(st.lists(st.binary(max_size=80), max_size=20))
def test_parser_fuzz_never_raises_and_stays_bounded(chunks: list[bytes]) -> None:
    parser = FrameParser()
    for chunk in chunks:
        for item in parser.feed(chunk):
            assert isinstance(item, (Frame, FrameError))
            if isinstance(item, FrameError):
                assert item.reason in wire.REASONS
                assert len(item.raw) <= MAX_LINE_BYTES + 1
        # The partial frame held never exceeds one maximal line (plus an allowed '\r').
        assert parser.buffered <= MAX_LINE_BYTES + 1


frames_strategy = st.builds(
    Frame,
    st.sampled_from("DHECTABNW"),
    st.integers(0, 65535),
    st.lists(st.sampled_from(["F", "L", "R", "S", "0", "3", "ESTOP", "300"]), max_size=2).map(
        tuple
    ),
)
noise_strategy = st.binary(max_size=30).map(lambda b: b.replace(b"$", b"").replace(b"\n", b""))


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(noise_strategy, frames_strategy), max_size=10))
def test_frames_survive_noise_between_them(items: list[tuple[bytes, Frame]]) -> None:
    wire = b"".join(noise + frame.encode() for noise, frame in items)
    decoded = [item for item in FrameParser().feed(wire) if isinstance(item, Frame)]
    assert decoded == [frame for _, frame in items]
