"""The myCobot 280's serial protocol, as the firmware speaks it (written from the frame layout
pymycobot 4.0.7 sends and parses; see docs/hardware.md).

A frame is ``0xFE 0xFE LEN CMD DATA... 0xFA`` with ``LEN = len(DATA) + 2`` (the command byte
and the footer count, the headers and LEN do not). Angles travel as big-endian int16 of
degrees x 100; the gripper value is one byte 0-100; a speed is one byte 1-100.
"""
from __future__ import annotations

import struct
from dataclasses import dataclass
from typing import Iterable, Sequence

HEADER = 0xFE
FOOTER = 0xFA
#: bits per byte on the wire: 8N1 (start bit, 8 data bits, stop bit)
BITS_PER_BYTE = 10


class Cmd:
    """Command bytes of the myCobot 280 firmware that the driver and pymycobot's MyCobot280 use."""

    SOFTWARE_VERSION = 0x02
    GET_ERROR_INFO = 0x07
    CLEAR_ERROR_INFO = 0x08
    POWER_ON = 0x10
    POWER_OFF = 0x11
    IS_POWER_ON = 0x12
    RELEASE_ALL_SERVOS = 0x13
    IS_CONTROLLER_CONNECTED = 0x14
    SET_FRESH_MODE = 0x16
    GET_FRESH_MODE = 0x17
    FOCUS_ALL_SERVOS = 0x18
    GET_ANGLES = 0x20
    SEND_ANGLE = 0x21
    SEND_ANGLES = 0x22
    PAUSE = 0x26
    IS_PAUSED = 0x27
    RESUME = 0x28
    STOP = 0x29
    IS_IN_POSITION = 0x2A
    IS_MOVING = 0x2B
    GET_SPEED = 0x40
    SET_SPEED = 0x41
    GET_GRIPPER_VALUE = 0x65
    SET_GRIPPER_STATE = 0x66
    SET_GRIPPER_VALUE = 0x67
    IS_GRIPPER_MOVING = 0x69
    GET_SERVO_STATUS = 0xE4

    NAMES = {}  # filled below: byte -> name


Cmd.NAMES = {v: k for k, v in vars(Cmd).items() if k.isupper() and isinstance(v, int)}


@dataclass(frozen=True)
class Frame:
    cmd: int
    data: bytes = b""

    def encode(self) -> bytes:
        return encode_frame(self.cmd, self.data)

    @property
    def name(self) -> str:
        return Cmd.NAMES.get(self.cmd, f"0x{self.cmd:02X}")


def encode_frame(cmd: int, data: bytes | Iterable[int] = b"") -> bytes:
    payload = bytes(data)
    if len(payload) > 250:
        raise ValueError(f"a frame carries at most 250 data bytes, got {len(payload)}")
    return bytes((HEADER, HEADER, len(payload) + 2, cmd & 0xFF)) + payload + bytes((FOOTER,))


def wire_seconds(n_bytes: int, baud: float) -> float:
    """Time `n_bytes` take on a serial line at `baud` (8N1)."""
    return n_bytes * BITS_PER_BYTE / float(baud)


class FrameParser:
    """Splits a byte stream into frames; bytes that do not form a frame are skipped (counted in
    ``skipped``), as the firmware resynchronises on the next double header."""

    def __init__(self) -> None:
        self._buffer = bytearray()
        self.skipped = 0

    def feed(self, chunk: bytes) -> list[Frame]:
        self._buffer += chunk
        frames: list[Frame] = []
        buf = self._buffer
        while True:
            start = _find_header(buf)
            if start < 0:
                keep = 1 if buf[-1:] == bytes((HEADER,)) else 0
                self.skipped += len(buf) - keep
                del buf[:len(buf) - keep]
                return frames
            if start:
                self.skipped += start
                del buf[:start]
            if len(buf) < 3:
                return frames
            length = buf[2]
            if length < 2 or length > 252:
                self.skipped += 1
                del buf[:1]
                continue
            total = 3 + length
            if len(buf) < total:
                return frames
            if buf[total - 1] != FOOTER:
                self.skipped += 1
                del buf[:1]
                continue
            frames.append(Frame(buf[3], bytes(buf[4:total - 1])))
            del buf[:total]


def _find_header(buf: bytearray) -> int:
    i = buf.find(bytes((HEADER, HEADER)))
    return i


# ------------------------------------------------------------------ values
def encode_angles(degrees: Sequence[float]) -> bytes:
    """int16 big-endian of degrees x 100 (truncated toward zero as the library does)."""
    return b"".join(struct.pack(">h", _int16(int(d * 100))) for d in degrees)


def decode_angles(data: bytes) -> list[float]:
    if len(data) % 2:
        raise ValueError(f"angle data must have an even length, got {len(data)} bytes")
    return [struct.unpack(">h", data[i:i + 2])[0] / 100.0 for i in range(0, len(data), 2)]


def _int16(value: int) -> int:
    return max(-32768, min(32767, value))
