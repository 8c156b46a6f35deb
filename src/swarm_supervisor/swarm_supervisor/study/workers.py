"""Where the local worker processes come from: a fork server with the engine loaded.

The pools of ``study``, ``calibrate``, ``evolve`` and ``heldout`` fork their workers from
multiprocessing's fork server (the ``forkserver`` start method, Python 3.14's default on
Linux). It is a fresh process, started by a program's first pool and kept until the program
ends, that imports :mod:`swarm_supervisor.study.preload` (the episode engine, numba's compiler
ready) before its first fork. A worker starts with all that in memory, where a spawned one
imported it again: about 1 CPU-s per worker. Like a spawned worker, a forked one shares
nothing else with the program (each pool's initializer loads the plug-ins, docs/plugins.md),
and the server forks no thread it does not own.

Each worker leaves the program's process group as it starts (:func:`pool`): a terminal's
Ctrl-C, or a SIGTERM sent to the group, reaches the program alone, which then ends its workers
itself. A worker killed by the group's signal while it held one of the pool's locks (taking a
task, handing back a result) left ``Pool.terminate()`` waiting for that lock for ever, and
the stopped study never exited.

A worker also dies with the program (:func:`_die_with`). A program killed outright
(``kill -9``, the OOM killer) left its workers, out of reach of a signal to its group, to
finish their batches and write episodes that the same command, run again to resume, was
writing too. (Linux's parent-death signal cannot do this: a worker's parent is the fork
server, which lives as long as any worker holds the pipe that tells it its program is alive.)
"""

from __future__ import annotations

import multiprocessing
import os
import select
import signal
import threading
from collections.abc import Callable
from multiprocessing.context import BaseContext
from multiprocessing.pool import Pool
from typing import Any

#: The start method of the local pools ('spawn' and 'fork' are accepted too).
START_METHOD = 'forkserver'
#: What the fork server imports before its first fork.
PRELOAD = ['swarm_supervisor.study.preload']


def context(method: str = START_METHOD) -> BaseContext:
    """The multiprocessing context of a pool: with 'forkserver', one whose server preloads
    :data:`PRELOAD` (if no pool of this program has started it yet)."""
    found = multiprocessing.get_context(method)
    if method == 'forkserver':
        found.set_forkserver_preload(PRELOAD)  # type: ignore[attr-defined]
    return found


def _die_with(program: int) -> None:
    """End this process when ``program`` does: a thread waits on the program's pidfd (Linux
    5.3 and later; elsewhere nothing: a worker then ends after its batch, when it hands back
    its result). A program already gone ends the worker at once."""
    try:
        handle = os.pidfd_open(program)
    except ProcessLookupError:
        os._exit(1)
    except (AttributeError, OSError):
        return

    def wait() -> None:
        select.select([handle], [], [])
        os.kill(os.getpid(), signal.SIGKILL)

    threading.Thread(target=wait, name='die-with-program', daemon=True).start()


def _detached(program: int, initializer: Callable[..., None] | None,
              initargs: tuple[Any, ...]) -> None:
    """Pool initializer: the worker dies with ``program``, has a process group of its own,
    leaves Ctrl-C to the program, and SIGTERM (the program terminating the pool) ends it also
    when it was forked with other handlers; then ``initializer(*initargs)``."""
    _die_with(program)
    os.setpgrp()
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    if initializer is not None:
        initializer(*initargs)


def pool(jobs: int, initializer: Callable[..., None] | None = None,
         initargs: tuple[Any, ...] = (), method: str = START_METHOD) -> Pool:
    """A pool of ``jobs`` worker processes from :func:`context` (``method``), each in a
    process group of its own, then set up by ``initializer(*initargs)``."""
    return context(method).Pool(jobs, initializer=_detached,  # type: ignore[attr-defined]
                                initargs=(os.getpid(), initializer, initargs))
