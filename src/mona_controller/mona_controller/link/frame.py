"""The link's frame and a streaming decoder that resynchronises after garbage.

Layout (docs/link.md, "Frame"; all multi-byte fields little-endian)::

    0xA5 | len | robot id | seq (2) | boot nonce (2) | type | payload (len) | CRC-16 (2)

The CRC (:mod:`.crc`) covers everything from ``len`` to the end of the payload. The decoder
counts every rejected frame by its reason (:data:`REASONS`); a frame's type and length must
agree (:data:`.payloads.SIZES`), so a valid CRC on a payload of the wrong size is a bad length.
"""

from __future__ import annotations

import struct
from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass

from .crc import crc16
from .payloads import SIZES

START = 0xA5
#: The bytes before the payload, and the CRC after it.
HEADER = struct.Struct('<BBBHHB')
CRC_SIZE = 2
MAX_PAYLOAD = 32
#: A broadcast robot id: every robot applies a command sent to it.
BROADCAST = 0xFF
#: Why the decoder rejected a frame.
BAD_CRC, TRUNCATED, BAD_LENGTH, BAD_TYPE = 'bad_crc', 'truncated', 'bad_length', 'bad_type'
REASONS = (BAD_CRC, TRUNCATED, BAD_LENGTH, BAD_TYPE)
#: Why :func:`check` refused bytes that do not begin with the start byte (the decoder skips
#: those as garbage instead).
BAD_START = 'bad_start'


class FrameError(ValueError):
    """A frame the link rejects; ``reason`` is one of :data:`REASONS`."""

    def __init__(self, reason: str, detail: str) -> None:
        super().__init__(f'{reason}: {detail}')
        self.reason = reason


@dataclass(frozen=True)
class Frame:
    """One frame: who sent it or is meant (``robot``), its sequence number and the sender's
    boot nonce (both 16-bit, wrapping), the payload type and bytes."""

    robot: int
    seq: int
    nonce: int
    kind: int
    payload: bytes

    def encode(self) -> bytes:
        """The frame's bytes on the wire."""
        if len(self.payload) > MAX_PAYLOAD:
            raise FrameError(BAD_LENGTH, f'{len(self.payload)} bytes > {MAX_PAYLOAD}')
        body = HEADER.pack(START, len(self.payload), self.robot, self.seq & 0xFFFF,
                           self.nonce & 0xFFFF, self.kind) + self.payload
        return body + struct.pack('<H', crc16(body[1:]))


def size(data: bytes | bytearray) -> int | None:
    """The length of the frame at the start of ``data`` (None until its header is in)."""
    if len(data) < HEADER.size:
        return None
    return HEADER.size + data[1] + CRC_SIZE


def check(data: bytes | bytearray) -> Frame:
    """The frame that is exactly ``data`` (FrameError naming the reason if it is not one)."""
    if data[:1] and data[0] != START:
        raise FrameError(BAD_START, f'first byte {data[0]:#04x}, not {START:#04x}')
    if len(data) < HEADER.size:
        raise FrameError(TRUNCATED, f'{len(data)} bytes, no complete header')
    start, length, robot, seq, nonce, kind = HEADER.unpack_from(data)
    if length > MAX_PAYLOAD:
        raise FrameError(BAD_LENGTH, f'length {length} > {MAX_PAYLOAD}')
    total = HEADER.size + length + CRC_SIZE
    if len(data) < total:
        raise FrameError(TRUNCATED, f'{len(data)} of {total} bytes')
    if len(data) > total:
        raise FrameError(BAD_LENGTH, f'{len(data)} bytes for a frame of {total}')
    expected, = struct.unpack_from('<H', data, total - CRC_SIZE)
    if crc16(data[1:total - CRC_SIZE]) != expected:
        raise FrameError(BAD_CRC, f'crc {crc16(data[1:total - CRC_SIZE]):#06x} != '
                         f'{expected:#06x}')
    if kind not in SIZES:
        raise FrameError(BAD_TYPE, f'payload type {kind:#04x}')
    if length != SIZES[kind]:
        raise FrameError(BAD_LENGTH, f'type {kind:#04x} with {length} bytes, not {SIZES[kind]}')
    return Frame(robot, seq, nonce, kind, bytes(data[HEADER.size:total - CRC_SIZE]))


class Decoder:
    """Frames from a byte stream, in order, whatever garbage lies between them.

    A frame whose CRC fails but holds the start of a valid frame is counted as truncated (a
    frame cut short by the next one, as a lost byte on a serial line leaves it); otherwise as a
    bad CRC. Bytes outside any frame are counted in :attr:`garbage`. :meth:`flush` ends the
    stream (e.g. a UDP datagram): a partial frame left over is truncated.
    """

    def __init__(self) -> None:
        self._buffer = bytearray()
        self.rejected: Counter[str] = Counter(dict.fromkeys(REASONS, 0))
        self.accepted = 0
        self.garbage = 0

    def feed(self, data: bytes) -> Iterator[Frame]:
        """The frames that ``data`` completes (a generator: consume it)."""
        self._buffer += data
        while (frame := self._next()) is not None:
            yield frame

    def flush(self) -> list[Frame]:
        """End of stream: the frames still whole in the buffer; a partial frame left over is
        counted truncated (once: start bytes inside it are garbage), and the buffer emptied."""
        found: list[Frame] = []
        truncated = False
        while True:
            found.extend(self.feed(b''))
            start = self._buffer.find(START)
            if start < 0:
                break
            if not truncated:
                self.rejected[TRUNCATED] += 1
                truncated = True
            else:
                self.garbage += 1
            del self._buffer[:start + 1]
        self.garbage += len(self._buffer)
        self._buffer.clear()
        return found

    def _reject(self, reason: str, drop: int) -> None:
        self.rejected[reason] += 1
        del self._buffer[:drop]

    def _next(self) -> Frame | None:
        buffer = self._buffer
        while True:
            start = buffer.find(START)
            if start < 0:
                self.garbage += len(buffer)
                buffer.clear()
                return None
            self.garbage += start
            del buffer[:start]
            total = size(buffer)
            if total is None:
                return None
            if buffer[1] > MAX_PAYLOAD:
                self._reject(BAD_LENGTH, 1)
                continue
            if len(buffer) < total:
                return None
            try:
                frame = check(buffer[:total])
            except FrameError as error:
                if error.reason != BAD_CRC:
                    self._reject(error.reason, total)
                    continue
                restart = self._restart(total)
                if restart == 0:  # a frame starts inside, still incomplete: wait for it
                    return None
                if restart is None:
                    self._reject(BAD_CRC, 1)
                else:
                    self._reject(TRUNCATED, restart)
                continue
            self.accepted += 1
            del buffer[:total]
            return frame

    def _restart(self, total: int) -> int | None:
        """Where a valid frame starts inside the first ``total`` bytes (0 while one that
        might be is incomplete; None if none does)."""
        buffer = self._buffer
        at = buffer.find(START, 1, total)
        while at >= 0:
            inner = size(buffer[at:])
            if inner is None or (buffer[at + 1] <= MAX_PAYLOAD and len(buffer) < at + inner):
                return 0
            try:
                check(buffer[at:at + inner])
            except FrameError:
                at = buffer.find(START, at + 1, total)
                continue
            return at
        return None
