"""Per-robot bookkeeping of sequence numbers and boot nonces: what the link lost, duplicated
and reordered, and when a robot rebooted.

Sequence numbers are 16-bit and wrap; a frame counts as ahead of the newest one if it is less
than half the range ahead (serial-number arithmetic, RFC 1982). A frame with a new boot nonce
is a reboot: the robot's sequence starts over and nothing is counted lost across it. A frame
with a nonce of an earlier boot arrives late from before the reboot: it is stale and dropped.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field

MODULUS = 1 << 16
HALF = MODULUS // 2
#: How many recent sequence numbers are remembered to tell duplicates from late frames.
WINDOW = 256
#: What :meth:`Tracker.observe` found a frame to be.
FIRST, NEXT, GAP, DUPLICATE, REORDERED, REBOOT, STALE = (
    'first', 'next', 'gap', 'duplicate', 'reordered', 'reboot', 'stale')
#: The verdicts whose frame is new and should be used.
FRESH = {FIRST, NEXT, GAP, REORDERED, REBOOT}


@dataclass
class Stream:
    """The bookkeeping of one robot's frames."""

    nonce: int | None = None
    first: int = 0
    newest: int = 0
    received: int = 0
    lost: int = 0
    duplicated: int = 0
    reordered: int = 0
    reboots: int = 0
    stale: int = 0
    recent: deque[int] = field(default_factory=lambda: deque(maxlen=WINDOW))
    old_nonces: set[int] = field(default_factory=set)

    def _restart(self, nonce: int, seq: int) -> None:
        self.nonce, self.first, self.newest = nonce, seq, seq
        self.recent.clear()
        self.recent.append(seq)

    def observe(self, seq: int, nonce: int) -> str:
        """Account for a frame; its verdict (one of FIRST ... STALE)."""
        if self.nonce is None:
            self._restart(nonce, seq)
            self.received += 1
            return FIRST
        if nonce != self.nonce:
            if nonce in self.old_nonces:
                self.stale += 1
                return STALE
            self.old_nonces.add(self.nonce)
            self._restart(nonce, seq)
            self.received += 1
            self.reboots += 1
            return REBOOT
        ahead = (seq - self.newest) % MODULUS
        if ahead == 0 or seq in self.recent:
            self.duplicated += 1
            return DUPLICATE
        self.received += 1
        self.recent.append(seq)
        if ahead < HALF:
            self.lost += ahead - 1
            self.newest = seq
            return NEXT if ahead == 1 else GAP
        # Behind the newest and not seen: late. Counted lost already, unless it precedes the
        # first frame we heard of this boot: then those between it and that one are lost.
        before = (self.first - seq) % MODULUS
        if 0 < before < HALF:
            self.lost += before - 1
            self.first = seq
        else:
            self.lost -= 1
        self.reordered += 1
        return REORDERED


class Tracker:
    """The streams of all robots, by robot id."""

    def __init__(self) -> None:
        self.streams: dict[int, Stream] = {}

    def observe(self, robot: int, seq: int, nonce: int) -> str:
        """Account for a frame from ``robot``; its verdict."""
        return self.streams.setdefault(robot, Stream()).observe(seq, nonce)


class Counter16:
    """The sequence numbers a sender stamps on its frames: 0, 1, ... 65535, 0, ..."""

    def __init__(self, start: int = 0) -> None:
        self._next = start % MODULUS

    def next(self) -> int:
        """The next sequence number."""
        seq, self._next = self._next, (self._next + 1) % MODULUS
        return seq
