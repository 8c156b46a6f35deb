"""Where the local worker processes come from: a fork server with the engine loaded.

The pools of ``study``, ``calibrate``, ``evolve`` and ``heldout`` fork their workers from
multiprocessing's fork server (the ``forkserver`` start method, Python 3.14's default on
Linux). It is a fresh process, started by a program's first pool and kept until the program
ends, that imports :mod:`swarm_supervisor.study.preload` (the episode engine, numba's compiler
ready) before its first fork. A worker starts with all that in memory, where a spawned one
imported it again: about 1 CPU-s per worker. Like a spawned worker, a forked one shares
nothing else with the program (each pool's initializer loads the plug-ins, docs/plugins.md),
and the server forks no thread it does not own.
"""

from __future__ import annotations

import multiprocessing
from multiprocessing.context import BaseContext

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
