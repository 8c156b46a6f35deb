"""What a node process does between fork and exec (:func:`~.processes.start_group`'s
``preexec_fn``): default SIGINT and SIGQUIT, no core file, and, for the launcher's nodes, a
signal when the launcher ends.

That last one is Linux's parent-death signal (prctl(2), ``PR_SET_PDEATHSIG``): it is sent when
the thread that started the process ends, and it survives exec. The launcher starts its nodes
from its main thread, so a node hears it when the launcher ends, however it ends: ``kill -9``
of scripts/swarm.sh (which execs the launcher) gives every node SIGINT, as a Ctrl-C's first
step would, and the metrics node closes its bag, where before the nodes ran on.
"""

from __future__ import annotations

import ctypes
import os
import resource
import signal
import sys

#: prctl(2)'s option: the signal this process gets when its parent ends.
_PR_SET_PDEATHSIG = 1
#: The C library, loaded before the fork (a child should only call into it).
_LIBC = ctypes.CDLL(None, use_errno=True) if sys.platform.startswith('linux') else None


def setup(parent: int, on_parent_death: int | None) -> None:
    """In a node process before exec: SIGINT and SIGQUIT as default (a background job starts
    with them ignored, and the nodes must stop on SIGINT), no core file from SIGABRT, and
    ``on_parent_death`` (a signal; None: nothing, and nothing off Linux) once ``parent`` (the
    starting process's pid) ends. A parent already gone ends the child before it execs."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    signal.signal(signal.SIGQUIT, signal.SIG_DFL)
    resource.setrlimit(resource.RLIMIT_CORE, (0, resource.getrlimit(resource.RLIMIT_CORE)[1]))
    if on_parent_death is not None and _LIBC is not None:
        _LIBC.prctl(_PR_SET_PDEATHSIG, int(on_parent_death))
        if os.getppid() != parent:  # it ended before the request took
            os._exit(128 + int(on_parent_death))
