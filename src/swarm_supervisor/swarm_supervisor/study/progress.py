"""The study's progress: sim seconds counted across worker processes, and a line per episode.

Workers add to one shared counter (a ``multiprocessing.Value``) every
:data:`PROGRESS_STEP` sim seconds of an episode; the parent shows it as a progress bar, and
counts each finished episode on another (:func:`show_done`).
"""

from __future__ import annotations

import sys
from pathlib import Path

from tqdm import tqdm

#: Sim seconds of an episode between two updates of the shared counter (it takes a lock).
PROGRESS_STEP = 10.0

_counter = None  # sim seconds done, shared by every worker of this process's pool


def init_worker(counter) -> None:
    """Pool initializer: share the progress counter (the signals are
    :mod:`swarm_supervisor.study.workers`' business)."""
    global _counter
    _counter = counter


def report(seconds: float) -> None:
    """Add ``seconds`` of sim time to the shared counter (nothing outside a pool)."""
    if _counter is not None and seconds > 0:
        with _counter.get_lock():
            _counter.value += seconds


def show_done(bar: tqdm, progress: bool | None, done: int, total: int, folder: str,
              wall: float) -> None:
    """Count a finished episode on the progress bar, or, when stderr is a log rather than a
    terminal (the bar is off by itself), print one line for it."""
    bar.update(1)
    bar.set_postfix_str(Path(folder).name, refresh=False)
    if bar.disable and progress is None:
        print(f'episode {done}/{total} done: {Path(folder).name} ({wall:.1f} s)',
              file=sys.stderr, flush=True)
