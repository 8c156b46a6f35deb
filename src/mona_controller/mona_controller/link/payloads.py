"""The two payloads of the link: a wheel command (host -> robot) and telemetry (robot -> host).

All fields little-endian (docs/link.md, "Payloads"). Wheel commands are in per-mille of the
wheel's full speed (-1000..1000), so the firmware needs no speed calibration: it maps them
through its deadband to PWM 0-255 and a direction bit.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

#: Payload type bytes.
COMMAND = 0x01
TELEMETRY = 0x81
#: The largest wheel command (per-mille of full speed).
FULL_SPEED = 1000
#: Command flags.
CLEANER = 0x01
#: Telemetry flags.
STOPPED = 0x01  # the firmware's 150 ms command watchdog holds the wheels at rest
CLEANING = 0x02  # the cleaner output is on
IR_COUNT = 5

_COMMAND = struct.Struct('<hhB')
_TELEMETRY = struct.Struct('<5HHHHHBB')


class PayloadError(ValueError):
    """A payload whose length or values do not fit its type."""


@dataclass(frozen=True)
class Command:
    """Wheel speeds (per-mille of full speed, + forward) and the cleaner."""

    left: int
    right: int
    cleaner: bool = False

    def encode(self) -> bytes:
        """The payload bytes."""
        for value in (self.left, self.right):
            if not -FULL_SPEED <= value <= FULL_SPEED:
                raise PayloadError(f'wheel command {value} outside +-{FULL_SPEED}')
        return _COMMAND.pack(self.left, self.right, CLEANER if self.cleaner else 0)

    @classmethod
    def decode(cls, payload: bytes) -> Command:
        """The command in ``payload`` (PayloadError if it has the wrong length)."""
        if len(payload) != _COMMAND.size:
            raise PayloadError(f'command of {len(payload)} bytes, not {_COMMAND.size}')
        left, right, flags = _COMMAND.unpack(payload)
        return cls(left, right, bool(flags & CLEANER))


@dataclass(frozen=True)
class Telemetry:
    """One report of the robot: raw IR (10-bit ADC, right to left, 1023 = nothing seen),
    wrapping encoder edge counters, battery (mV), flags, the sequence number of the last
    command applied and the firmware's count of rejected frames (wrapping)."""

    ir: tuple[int, int, int, int, int]
    left_ticks: int
    right_ticks: int
    battery_mv: int
    ack: int
    flags: int
    rx_rejected: int

    @property
    def stopped(self) -> bool:
        """Whether the firmware's command watchdog holds the wheels at rest."""
        return bool(self.flags & STOPPED)

    def encode(self) -> bytes:
        """The payload bytes."""
        return _TELEMETRY.pack(*self.ir, self.left_ticks, self.right_ticks, self.battery_mv,
                               self.ack, self.flags, self.rx_rejected)

    @classmethod
    def decode(cls, payload: bytes) -> Telemetry:
        """The telemetry in ``payload`` (PayloadError if it has the wrong length or an IR
        value above 10 bits)."""
        if len(payload) != _TELEMETRY.size:
            raise PayloadError(f'telemetry of {len(payload)} bytes, not {_TELEMETRY.size}')
        values = _TELEMETRY.unpack(payload)
        ir = values[:IR_COUNT]
        if max(ir) > 1023:
            raise PayloadError(f'IR reading above 10 bits: {ir}')
        return cls((ir[0], ir[1], ir[2], ir[3], ir[4]), *values[IR_COUNT:])


#: The payload length each type must have.
SIZES = {COMMAND: _COMMAND.size, TELEMETRY: _TELEMETRY.size}
