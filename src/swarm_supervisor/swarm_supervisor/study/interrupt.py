"""Stopping a study on request without losing a finished episode.

While episodes run, the parent process handles SIGINT (Ctrl-C) and SIGTERM itself
(:class:`StopRequest`): either stops the study at once. The running batches are cut: their
episodes, which a batch steps together and which all end together at its duration, are
lost and run again next time, while every episode finished before stays (each episode folder
is written under a temporary name and renamed into place, so a stop, or a second Ctrl-C,
never leaves one half-written). A stop is prompt, as a process manager's SIGTERM grace
period needs, and loses at most one batch's time on each worker.

The study then raises :class:`Interrupted`; the command line says how many episodes are kept
and exits 130 (SIGINT) or 143 (SIGTERM); the same command resumes.
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


class Interrupted(KeyboardInterrupt):
    """The study stopped on a signal; ``ran`` holds what finished before (folder -> (wall s,
    CPU s)), ``signum`` the first signal received. A KeyboardInterrupt, so code that cleans
    up after Ctrl-C does so after SIGTERM too."""

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
        return (f'interrupted by {self.name}: {self.kept} of {self.total} episodes kept in '
                f'{self.folder} (the running batches were cut); rerun the same command to '
                'resume')

    def announce(self) -> None:
        """Say on stderr, as the stop begins, that it does (the workers take a moment to end)."""
        print(f'{self.name} received: stopping the workers; finished episodes are kept',
              file=sys.stderr, flush=True)

    @property
    def status(self) -> int:
        """The process exit status: 130 for SIGINT, 143 for SIGTERM."""
        return STATUS.get(signal.Signals(self.signum), exits.INTERRUPTED)

    @property
    def name(self) -> str:
        """The signal's name, e.g. ``SIGINT``."""
        return signal.Signals(self.signum).name


class StopRequest:
    """Signal handlers for the time episodes run: SIGINT and SIGTERM raise
    :class:`Interrupted` in the main thread (a context manager; it restores the previous
    handlers on exit). A later signal while the study stops (terminating the workers,
    recording what it kept) changes nothing. Nested, an inner request that received a signal
    hands it to the outer one as it exits; the outermost one raises :class:`Interrupted` as
    it exits if it received a signal whose exception was lost (see :func:`raise_if_stopped`),
    so a command never ends as if no signal had come."""

    def __init__(self) -> None:
        #: The first signal received, or None.
        self.requested: int | None = None
        self._previous: dict[int, Any] = {}

    def __enter__(self) -> StopRequest:
        if threading.current_thread() is threading.main_thread():  # handlers live there only
            for signum in STATUS:
                self._previous[signum] = signal.signal(signum, self._handle)
            _ACTIVE.append(self)
        return self

    def __exit__(self, kind: type[BaseException] | None, *exc: object) -> None:
        for signum, handler in self._previous.items():
            signal.signal(signum, handler)
        if self not in _ACTIVE:
            return
        _ACTIVE.remove(self)
        if self.requested is None:
            return
        if _ACTIVE:  # the enclosing request stops at its next check, or as it exits
            if _ACTIVE[-1].requested is None:
                _ACTIVE[-1].requested = self.requested
        elif kind is None:  # the handler's exception was lost on the way
            raise Interrupted(self.requested)

    def _handle(self, signum: int, frame: FrameType | None) -> None:
        if self.requested is not None:
            return  # already stopping: let the cleanup finish
        self.requested = signum
        raise Interrupted(signum)


#: The stop requests in force, innermost last.
_ACTIVE: list[StopRequest] = []


def raise_if_stopped(ran: dict[str, tuple[float, float]] | None = None) -> None:
    """Raise :class:`Interrupted` (with ``ran``, what finished) if a stop request in force
    received a signal.

    The handler's exception is lost when the signal lands while Python runs a weakref
    callback or a ``__del__`` (it only prints "Exception ignored in ..."): a Ctrl-C amid
    optuna's bookkeeping let a calibration search run on to its end. Loops that run long
    call this between their steps, so such a signal still stops them there.
    """
    for request in _ACTIVE:
        if request.requested is not None:
            raise Interrupted(request.requested, ran)


def exit_status(stop: KeyboardInterrupt) -> int:
    """A command's exit status after ``stop``: 130 for SIGINT (a plain Ctrl-C too), 143 for
    SIGTERM."""
    return stop.status if isinstance(stop, Interrupted) else exits.INTERRUPTED
