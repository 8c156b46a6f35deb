"""Stopping a study on request without losing a finished episode.

While episodes run, the parent process handles the signals itself (:class:`StopRequest`):

- the first SIGINT (Ctrl-C) starts no more batches, lets the running ones finish (a batch's
  episodes all end together, at its duration; each is written as it ends) and then stops:
  nothing that was already computed is thrown away;
- a second SIGINT stops at once: the running batches are cut and their episodes lost (each
  episode folder is written under a temporary name and renamed into place, so none is left
  half-written);
- SIGTERM (a process manager, a cluster's preemption) stops at once, as a second Ctrl-C.

Either way the study raises :class:`Interrupted`, and the command line says how many
episodes are kept and exits 130 (SIGINT) or 143 (SIGTERM); the same command resumes.
"""

from __future__ import annotations

import signal
import sys
import threading
from types import FrameType
from typing import Any

from swarm_supervisor import exits

#: The exit status for each signal that stops a study.
STATUS = {signal.SIGINT: exits.INTERRUPTED, signal.SIGTERM: exits.TERMINATED}


class Interrupted(Exception):
    """The study stopped on a signal; ``ran`` holds what finished before (folder -> (wall s,
    CPU s)), ``signum`` the first signal received."""

    def __init__(self, signum: int, ran: dict[str, tuple[float, float]] | None = None) -> None:
        super().__init__(f'stopped by {signal.Signals(signum).name}')
        self.signum = signum
        self.ran = dict(ran or {})
        #: Set by the study: the episodes of the design complete in its folder, of how many.
        self.kept = 0
        self.total = 0
        self.folder = ''

    def message(self) -> str:
        """What the command line says: how much is kept, and how to go on."""
        return (f'{self.name}: {self.kept} of {self.total} episodes kept in {self.folder}; '
                'rerun the same command to resume')

    @property
    def status(self) -> int:
        """The process exit status: 130 for SIGINT, 143 for SIGTERM."""
        return STATUS.get(signal.Signals(self.signum), exits.INTERRUPTED)

    @property
    def name(self) -> str:
        """The signal's name, e.g. ``SIGINT``."""
        return signal.Signals(self.signum).name


class StopRequest:
    """Signal handlers for the time episodes run (a context manager; it restores the
    previous handlers on exit).

    Args:
        graceful: the first SIGINT only sets :attr:`requested` (the caller stops starting
            batches and finishes the running ones); false: it stops at once, as SIGTERM.
        running: called in the handler for a description of what will still be finished,
            e.g. '2 running batches (30 episodes)'.
    """

    def __init__(self, *, graceful: bool = True, running: Any = None) -> None:
        self.graceful = graceful
        self.running = running
        #: The first signal received, or None.
        self.requested: int | None = None
        self._previous: dict[int, Any] = {}

    def __enter__(self) -> StopRequest:
        if threading.current_thread() is threading.main_thread():  # handlers live there only
            for signum in STATUS:
                self._previous[signum] = signal.signal(signum, self._handle)
        return self

    def __exit__(self, *exc: object) -> None:
        for signum, handler in self._previous.items():
            signal.signal(signum, handler)

    def _handle(self, signum: int, frame: FrameType | None) -> None:
        first = self.requested is None
        if first:
            self.requested = signum
        if first and self.graceful and signum == signal.SIGINT:
            what = self.running() if self.running else 'the running batches'
            print(f'\nmona-swarm study: SIGINT: finishing {what} and starting no more '
                  '(Ctrl-C again to stop now and lose them)', file=sys.stderr, flush=True)
            return
        raise Interrupted(self.requested or signum)

    def check(self, ran: dict[str, tuple[float, float]]) -> None:
        """Raise :class:`Interrupted` (with ``ran``) if a stop was requested."""
        if self.requested is not None:
            raise Interrupted(self.requested, ran)
