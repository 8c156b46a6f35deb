"""The world's rounds with its controllers, as plain Python (no ROS): docs/interfaces.md,
"Stepping".

**Lockstep.** Each step is a round: the world publishes readings stamped ``expected_ns`` and
waits for each present robot's command with exactly that stamp, or for a deadline. A robot
that misses the deadline holds still for the step; after ``absent_after`` misses in a row it
is absent, no longer waited for, kept still and its cleaner off, until it answers any stamp of
the episode again. A command stamped for another step is dropped; a second one for the step a
robot last answered is a duplicate (the first one counts), also once that round is over: the
answers a robot repeats to step 0's repeated readings may cross the world's next round.

**Realtime.** The world steps on its own clock with each robot's latest command; one that
answers readings more than ``absent_after`` steps old holds still and is absent.

The world node feeds the messages in and applies :meth:`Lockstep.commands`; the tests drive
the same class directly.
"""

from __future__ import annotations

import dataclasses
import enum
import math
from typing import Any

import numpy as np


class Outcome(str, enum.Enum):
    """What became of one command."""

    ACCEPTED = 'accepted'  #: the robot's command for the open round
    DROPPED = 'dropped'  #: stamped for another step, or for a round that is over: counted
    DUPLICATE = 'duplicate'  #: the robot already answered this stamp: counted, not applied
    IGNORED = 'ignored'  #: from a robot that is not in the episode


@dataclasses.dataclass(frozen=True)
class Answer:
    """The outcome of a command, whether it brought its robot back, and whether the round it
    answered is now complete (every robot it waited for has answered)."""

    outcome: Outcome
    rejoined: bool = False  #: the robot was absent and is present again
    complete: bool = False  #: the round is over: apply the commands and step


class Lockstep:
    """The commands, misses and absences of one episode's robots.

    Args:
        population: the episode's robots, ids ``0 .. population - 1``.
        start_ns: sim time of the episode's step 0 (older stamps are not of this episode).
        absent_after: misses in a row after which a robot is absent.
        step_ns: a round's period, the control step (realtime: a command is stale after
            ``absent_after`` of them).
    """

    def __init__(self, population: int, start_ns: int, absent_after: int,
                 step_ns: int) -> None:
        self.population = population
        self.start_ns = start_ns
        self.absent_after = absent_after
        self.step_ns = step_ns
        self.linear = np.zeros(population)
        self.angular = np.zeros(population)
        self.cleaner = np.zeros(population, dtype=bool)  #: each robot's latest cleaner state
        self.misses = np.zeros(population, dtype=np.int64)
        self.consecutive = np.zeros(population, dtype=np.int64)  #: misses in a row
        self.absent = np.zeros(population, dtype=bool)
        self.dropped = 0
        self.duplicates = 0
        self.expected_ns = -1  #: the stamp of the latest round
        self.open = False  #: the latest round still takes commands
        self.answered_ns = np.full(population, -1, dtype=np.int64)  # last accepted stamps
        self.awaited = np.zeros(population, dtype=bool)  # this round waits for them still
        self.pending = 0  # count of awaited, kept as an int for the hot path
        self.command_ns = np.full(population, -1, dtype=np.int64)  # realtime: latest stamps

    # --- lockstep ---------------------------------------------------------------------------

    def start_round(self, expected_ns: int) -> None:
        """Open the round of the readings stamped ``expected_ns``: wait for every present
        robot; until it answers, a robot holds still."""
        self.expected_ns = expected_ns
        self.open = True
        self.linear[:] = 0.0
        self.angular[:] = 0.0
        np.logical_not(self.absent, out=self.awaited)
        self.pending = int(np.count_nonzero(self.awaited))

    def waiting(self) -> np.ndarray:
        """The robots the open round still waits for (ids, ascending)."""
        return np.flatnonzero(self.awaited)

    def answer(self, robot: int, stamp_ns: int, linear: float, angular: float) -> Answer:
        """A robot's command (``cmd_vel``): ``stamp_ns`` is the stamp of the readings it
        answers. Non-finite speeds become a stop (a broken controller must not break the
        physics).

        An absent robot that answers any stamp of the episode up to the latest round's
        (``start_ns <= stamp_ns <= expected_ns``) is present again: the current round takes
        its command if the stamp is the current one, and the next round waits for it.
        """
        if not 0 <= robot < self.population:
            return Answer(Outcome.IGNORED)
        rejoined = bool(self.absent[robot]) and self.start_ns <= stamp_ns <= self.expected_ns
        if rejoined:
            self.absent[robot] = False
            self.consecutive[robot] = 0
        if stamp_ns == self.answered_ns[robot]:  # a repeat, in this round or after it
            self.duplicates += 1
            return Answer(Outcome.DUPLICATE, rejoined)
        if stamp_ns != self.expected_ns or not self.open:
            self.dropped += 1
            return Answer(Outcome.DROPPED, rejoined)
        if not (math.isfinite(linear) and math.isfinite(angular)):
            linear = angular = 0.0
        self.answered_ns[robot] = stamp_ns
        self.linear[robot], self.angular[robot] = linear, angular
        self.consecutive[robot] = 0
        if self.awaited[robot]:
            self.awaited[robot] = False
            self.pending -= 1
        # A rejoining robot's answer completes a round that waited for nobody.
        self.open = self.pending > 0
        return Answer(Outcome.ACCEPTED, rejoined, complete=not self.open)

    def deadline(self) -> tuple[np.ndarray, np.ndarray]:
        """The round's deadline passed: close it. The robots it still waited for hold still
        and miss the step; those that missed ``absent_after`` in a row become absent.

        Returns:
            (late, newly absent): robot ids, ascending.
        """
        late = np.flatnonzero(self.awaited)
        self.misses[late] += 1
        self.consecutive[late] += 1
        gone = late[self.consecutive[late] >= self.absent_after]
        self.absent[gone] = True
        self.awaited[:] = False
        self.pending = 0
        self.open = False
        return late, gone

    # --- both modes -------------------------------------------------------------------------

    def set_cleaner(self, robot: int, on: bool) -> None:
        """A robot's cleaner (``cleaner``): its latest state counts."""
        if 0 <= robot < self.population:
            self.cleaner[robot] = on

    def commands(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The step's (linear [N], angular [N], cleaner [N]); an absent robot does not clean.
        The speed arrays are the core's own: use them before the next message."""
        return self.linear, self.angular, self.cleaner & ~self.absent

    def counters(self) -> dict[str, Any]:
        """``misses`` per robot, ``absent`` robot ids, ``dropped`` and ``duplicates``, as
        /world/status reports them."""
        return {'misses': self.misses.tolist(), 'absent': np.flatnonzero(self.absent).tolist(),
                'dropped': self.dropped, 'duplicates': self.duplicates}

    # --- realtime ---------------------------------------------------------------------------

    def keep_latest(self, robot: int, stamp_ns: int, linear: float, angular: float) -> None:
        """Realtime: keep a robot's command if it is its newest (by stamp)."""
        if not 0 <= robot < self.population or stamp_ns < self.command_ns[robot]:
            return
        if not (math.isfinite(linear) and math.isfinite(angular)):
            linear = angular = 0.0
        self.command_ns[robot] = stamp_ns
        self.linear[robot], self.angular[robot] = linear, angular

    def realtime_step(self, time_ns: int) -> None:
        """Realtime: the step from ``time_ns`` (the stamp of the latest readings) is due. A
        robot without a command for those readings misses it; one whose latest command answers
        readings more than ``absent_after`` steps old is absent and holds still."""
        stale = self.command_ns < time_ns - self.absent_after * self.step_ns
        self.misses[self.command_ns < time_ns] += 1
        self.absent[:] = stale
        self.linear[stale] = 0.0
        self.angular[stale] = 0.0
