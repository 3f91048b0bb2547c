"""Line-framed ASCII wire protocol between host and robot board (for users: hardware/README.md).

Frame: ``$<type>,<seq>[,<arg>]*<CRC>\\n`` where CRC is CRC-16/CCITT-FALSE (poly 0x1021, init
0xFFFF) over the bytes between ``$`` and ``*``, as 4 upper-case hex digits. A ``$`` always starts
a new frame; a line longer than ``MAX_LINE_BYTES`` (counting ``$`` up to, not including, the
newline) is rejected; the receive buffer never grows past that bound.
"""

from __future__ import annotations

import binascii
from dataclasses import dataclass

DEFAULT_BAUD = 9600  # the firmware's UART rate (HC-05/06 factory default)
MAX_LINE_BYTES = 31

# Host -> board frame types.
DRIVE = "D"  # arg: F, L, R or S
PING = "H"
ESTOP = "E"  # latched emergency stop
CLEAR = "C"  # clear the e-stop (does not restart motion)
SET_WATCHDOG = "T"  # arg: period in ms, 50..2000
VERSION = "V"  # version query: acked with more args: firmware version, reset cause, boot count
HELLO = "K"  # arg: the boot count of the board's boot frame; drive frames are obeyed after it
# Board -> host frame types.
ACK = "A"  # args: state, flags
NAK = "N"  # arg: reason
BOOT = "B"  # seq 0, args: version, reset cause, flags, boot count (1.1: no count; 1.0: version)
WATCHDOG_STOP = "W"  # seq 0, arg: S

DRIVE_ARGS = ("F", "L", "R", "S")
WATCHDOG_MIN_MS = 50
WATCHDOG_MAX_MS = 2000
SEQ_MODULO = 65536

# Reject reasons carried by NAK frames (and reported by FrameParser for malformed input).
REASON_CRC = "CRC"
REASON_FRAME = "FRAME"
REASON_ARG = "ARG"
REASON_ESTOP = "ESTOP"
REASON_TYPE = "TYPE"
REASON_LONG = "LONG"
REASON_BOOT = "BOOT"  # a moving drive before the host answered this boot (or a hello for another)
REASONS = (
    REASON_CRC,
    REASON_FRAME,
    REASON_ARG,
    REASON_ESTOP,
    REASON_TYPE,
    REASON_LONG,
    REASON_BOOT,
)

# Reset causes in boot frames and version replies (from the board's MCU status register).
RESET_CAUSES = {
    "PWR": "power-on",
    "EXT": "reset pin",
    "BOD": "brown-out",
    "WDT": "hardware watchdog",
    "?": "not recorded",  # a bootloader cleared the register before the firmware read it
}


def crc16(body: bytes) -> int:
    """CRC-16/CCITT-FALSE of ``body`` (same as avr-libc ``_crc_xmodem_update`` from 0xFFFF)."""
    return binascii.crc_hqx(body, 0xFFFF)


@dataclass(frozen=True)
class Frame:
    """One decoded frame."""

    type: str
    seq: int
    args: tuple[str, ...] = ()

    def encode(self) -> bytes:
        """Wire bytes of this frame, newline included."""
        return encode_frame(self.type, self.seq, *self.args)


@dataclass(frozen=True)
class FrameError:
    """A line that could not be decoded, with the NAK reason that describes it."""

    reason: str
    raw: bytes


def encode_frame(frame_type: str, seq: int, *args: str) -> bytes:
    """Encode one frame (newline included).

    Raises ValueError, and nothing else, for anything that is not a valid frame: a type that is
    not one ASCII letter, a seq that is not an int in 0..65535, an argument that is not a
    non-empty ASCII string free of ``,*$`` and line breaks, or a line over ``MAX_LINE_BYTES``.
    """
    if not isinstance(frame_type, str) or len(frame_type) != 1 or not _is_ascii_letter(frame_type):
        raise ValueError(f"frame type must be one ASCII letter, got {frame_type!r}")
    if not isinstance(seq, int) or isinstance(seq, bool) or not 0 <= seq < SEQ_MODULO:
        raise ValueError(f"seq must be an int in 0..{SEQ_MODULO - 1}, got {seq!r}")
    for arg in args:
        if (
            not isinstance(arg, str)
            or not arg
            or any(c in arg for c in ",*$\r\n")
            or not arg.isascii()
        ):
            raise ValueError(f"bad frame argument {arg!r}")
    body = ",".join([frame_type, str(seq), *args]).encode("ascii")
    line = b"$" + body + b"*" + f"{crc16(body):04X}".encode("ascii")
    if len(line) > MAX_LINE_BYTES:
        raise ValueError(f"frame longer than {MAX_LINE_BYTES} bytes: {line!r}")
    return line + b"\n"


_HEX_DIGITS = frozenset(b"0123456789abcdefABCDEF")


def _is_ascii_letter(text: str) -> bool:
    return text.isascii() and text.isalpha()


def decode_line(line: bytes) -> Frame | FrameError:
    """Decode one line that starts with ``$`` (newline and any ``\\r`` stripped); never raises.

    Rejects exactly what the firmware rejects, for the same reason (``REASON_*``).
    """
    line = line.rstrip(b"\r")
    if len(line) > MAX_LINE_BYTES:
        return FrameError(REASON_LONG, line)
    if not line.startswith(b"$") or line.count(b"*") != 1:
        return FrameError(REASON_FRAME, line)
    body, _, crc_text = line[1:].partition(b"*")
    # Exactly four hex digits: int(x, 16) alone would also take " ABC", "+ABC" or "A_BC".
    if len(crc_text) != 4 or not _HEX_DIGITS.issuperset(crc_text):
        return FrameError(REASON_FRAME, line)
    crc = int(crc_text, 16)
    if crc != crc16(body):
        return FrameError(REASON_CRC, line)
    try:
        fields = body.decode("ascii").split(",")
    except UnicodeDecodeError:
        return FrameError(REASON_FRAME, line)
    if len(fields) < 2 or len(fields[0]) != 1 or not _is_ascii_letter(fields[0]):
        return FrameError(REASON_FRAME, line)
    if not fields[1].isdigit() or len(fields[1]) > 5 or int(fields[1]) >= SEQ_MODULO:
        return FrameError(REASON_FRAME, line)
    return Frame(fields[0], int(fields[1]), tuple(fields[2:]))


class FrameParser:
    """Incremental, bounded parser: feed bytes, get frames and errors in arrival order.

    Bytes outside a frame (before any ``$``) are skipped; a ``$`` restarts the frame in progress
    (resynchronisation); a frame growing past ``MAX_LINE_BYTES`` is reported once as too long and
    the rest of it up to the newline is dropped. Memory held is at most ``MAX_LINE_BYTES`` bytes.
    """

    def __init__(self) -> None:
        self._buf = bytearray()
        self._in_frame = False
        self._overflow = False

    @property
    def buffered(self) -> int:
        """Bytes currently held for an unfinished frame."""
        return len(self._buf)

    def feed(self, data: bytes) -> list[Frame | FrameError]:
        """Consume ``data``; return every complete frame or error it finished."""
        out: list[Frame | FrameError] = []
        for byte in data:
            if byte == 0x24:  # '$' always starts a new frame
                self._buf.clear()
                self._buf.append(byte)
                self._in_frame = True
                self._overflow = False
            elif not self._in_frame:
                continue
            elif byte == 0x0A:  # '\n' ends the frame
                if self._overflow:
                    out.append(FrameError(REASON_LONG, bytes(self._buf)))
                else:
                    out.append(decode_line(bytes(self._buf)))
                self._buf.clear()
                self._in_frame = False
                self._overflow = False
            elif self._overflow:
                continue
            elif len(self._buf) >= MAX_LINE_BYTES + 1:  # +1 allows a trailing '\r'
                self._overflow = True
            else:
                self._buf.append(byte)
        return out
