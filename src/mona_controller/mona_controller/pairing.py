"""What a controller node decides without ROS: which readings to answer, and when to log.

:class:`ReadingPairs` keeps the rules of docs/interfaces.md ("What a driver (or world) can rely
on") for one robot: the ``ground`` and ``proximity`` halves of a reading are paired by stamp
in either order, each pair is answered once, a repeat gets the remembered answer again, and
unmatched halves are bounded. :class:`RateLimitedLog` logs each kind of bad input at most once
per period. Both are plain Python, so the node only converts messages and publishes.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any, Generic, TypeVar

#: Unmatched halves kept per topic while the other half of the pair is on its way.
PENDING_LIMIT = 16
#: Answered stamps remembered, so that a repeat of one of them gets the same answer.
ANSWER_HISTORY = 16
#: Seconds between two log lines of the same kind of bad input.
WARN_EVERY = 5.0

Ground = TypeVar('Ground')
Proximity = TypeVar('Proximity')
Answer = TypeVar('Answer')


class ReadingPairs(Generic[Ground, Proximity, Answer]):
    """Pairs one robot's ground and proximity halves by stamp and answers each stamp once.

    ``answer(stamp, ground, proximity)`` computes the answer to a new pair. Within an episode
    it is called at most once per stamp, in increasing stamp order and never for a stamp
    before the episode's start, so a stateful controller sees time run forward. Readings
    stay pending until the first episode starts. The answers to the last ``history`` stamps
    are remembered: a pair repeated with one of them gets that answer again. Any other pair
    older than the latest answer can no longer be answered and is dropped.

    ``add_ground``, ``add_proximity`` and ``start`` return the ``(stamp, answer)`` pairs to
    publish, in stamp order (at most one for a half).
    """

    def __init__(self, answer: Callable[[int, Ground, Proximity], Answer], *,
                 pending_limit: int = PENDING_LIMIT, history: int = ANSWER_HISTORY) -> None:
        self._answer = answer
        self.pending_limit = pending_limit
        self.history = history
        self.start_ns: int | None = None  #: the episode's start, None before the first
        self.ground: dict[int, Ground] = {}  #: unmatched ground halves by stamp
        self.proximity: dict[int, Proximity] = {}  #: unmatched proximity halves by stamp
        self.answers: dict[int, Answer] = {}  #: the remembered answers, oldest stamp first

    def start(self, start_ns: int) -> list[tuple[int, Answer]]:
        """Begin an episode at ``start_ns``: forget the answers and halves from before it,
        and answer the pairs that are already complete."""
        self.start_ns = start_ns
        self.answers.clear()
        self._drop_unanswerable()
        return [self._take(stamp) for stamp in sorted(self.ground.keys() & self.proximity)]

    def add_ground(self, stamp: int, reading: Ground) -> list[tuple[int, Answer]]:
        """Take the ground half of the readings stamped ``stamp``."""
        return self._add(self.ground, stamp, reading)

    def add_proximity(self, stamp: int, reading: Proximity) -> list[tuple[int, Answer]]:
        """Take the proximity half of the readings stamped ``stamp``."""
        return self._add(self.proximity, stamp, reading)

    def _add(self, halves: dict[int, Any], stamp: int,
             reading: object) -> list[tuple[int, Answer]]:
        if not self._answerable(stamp):
            return []
        halves[stamp] = reading
        if self.start_ns is None or stamp not in self.ground or stamp not in self.proximity:
            while len(halves) > self.pending_limit:  # a lost half must not pile up
                del halves[min(halves)]
            return []
        return [self._take(stamp)]

    def _take(self, stamp: int) -> tuple[int, Answer]:
        """Answer the complete pair of ``stamp``: the remembered answer or a new one."""
        ground, proximity = self.ground.pop(stamp), self.proximity.pop(stamp)
        if stamp in self.answers:
            return stamp, self.answers[stamp]  # a repeat: the same answer, not recomputed
        answer = self._answer(stamp, ground, proximity)
        self.answers[stamp] = answer
        if len(self.answers) > self.history:
            del self.answers[next(iter(self.answers))]
        self._drop_unanswerable()
        return stamp, answer

    def _answerable(self, stamp: int) -> bool:
        """Whether a pair stamped ``stamp`` could still get an answer."""
        if self.start_ns is None:
            return True  # time is not known yet: keep everything
        if stamp < self.start_ns:
            return False
        latest = next(reversed(self.answers), None)
        return latest is None or stamp > latest or stamp in self.answers

    def _drop_unanswerable(self) -> None:
        for halves in (self.ground, self.proximity):
            for stamp in [s for s in halves if not self._answerable(s)]:
                del halves[stamp]


class RateLimitedLog:
    """Logs each kind of message at most once per ``period`` seconds (kinds do not share it).

    ``clock`` gives the time in seconds (monotonic wall time unless a test passes its own).
    """

    def __init__(self, log: Callable[[str], None], period: float = WARN_EVERY,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.log = log
        self.period = period
        self.clock = clock
        self.last: dict[str, float] = {}  #: kind -> when it was last logged

    def __call__(self, kind: str, text: str) -> bool:
        """Log ``text`` unless ``kind`` was logged within the period; True if logged."""
        now = self.clock()
        last = self.last.get(kind)
        if last is not None and now - last < self.period:
            return False
        self.last[kind] = now
        self.log(text)
        return True
