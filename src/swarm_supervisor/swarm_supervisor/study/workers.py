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
"""

from __future__ import annotations

import multiprocessing
import os
import signal
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


def _detached(initializer: Callable[..., None] | None, initargs: tuple[Any, ...]) -> None:
    """Pool initializer: a process group of the worker's own, Ctrl-C left to the program,
    SIGTERM (the program terminating the pool) ending the worker also when it was forked
    with other handlers; then ``initializer(*initargs)``."""
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
                                initargs=(initializer, initargs))
