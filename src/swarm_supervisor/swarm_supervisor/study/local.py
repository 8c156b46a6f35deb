"""The study's episodes on local worker processes (a multiprocessing pool)."""

from __future__ import annotations

import multiprocessing
import os
import sys
from collections.abc import Sequence

from tqdm import tqdm

from mona_controller import plugins
from mona_controller.plugins import Plugin
from swarm_supervisor.study import progress, workers
from swarm_supervisor.study.errors import StudyError
from swarm_supervisor.study.interrupt import Interrupted
from swarm_supervisor.study.tasks import EpisodeTask, run_and_write
from swarm_supervisor.study.workers import START_METHOD


def available_cpus() -> int:
    """The CPUs this process may use."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def _init_worker(counter, started, records: tuple[Plugin, ...]) -> None:
    """Pool initializer: count the worker, load the study's plug-ins before any task reaches
    it (a task's configuration holds their classes: a worker started afresh could not unpickle it),
    then share the progress counter."""
    with started.get_lock():
        started.value += 1
    plugins.ensure(records)
    progress.init_worker(counter)


def run_local(batches: Sequence[Sequence[EpisodeTask]], jobs: int, shown: bool | None,
              start_method: str = START_METHOD) -> dict[str, tuple[float, float]]:
    """Run the batches of tasks (:func:`~swarm_supervisor.study.tasks.make_batches`) over a
    pool of ``jobs`` processes, with progress bars (``shown``: True, False, or None for only
    on a terminal).

    Ctrl-C, SIGTERM (:mod:`~swarm_supervisor.study.interrupt`) or a failed episode terminates
    every worker at once; the episodes written by then stay on disk.

    Returns:
        folder -> (wall seconds, CPU seconds) of each episode (its share of its batch's),
        writing included.

    Raises:
        Interrupted: stopped by a signal; its ``ran`` holds the episodes finished before.
        StudyError: a worker process died (killed, or crashed in native code): the pool
            would start another, but the episodes it held are lost, and waiting for them
            would never end.
    """
    pending = [task for batch in batches for task in batch]
    if not pending:
        return {}
    shared = workers.context(start_method)
    counter = shared.Value('d', 0.0)
    started = shared.Value('i', 0)  # workers started: more than ``jobs`` means one died
    total = sum(task.config.episode.duration for task in pending)
    ran: dict[str, tuple[float, float]] = {}
    pool = workers.pool(jobs, _init_worker, (counter, started, tuple(pending[0].config.plugins)),
                        start_method)
    bar_format = '{desc}: {percentage:3.0f}%|{bar}| {n:.0f}/{total:.0f} {unit} ' \
                 '[{elapsed}<{remaining}]'
    disable = None if shown is None else not shown
    try:
        with tqdm(total=len(pending), desc='episodes', unit='episodes', position=0,
                  disable=disable, file=sys.stderr, bar_format=bar_format) as episodes, \
             tqdm(total=total, desc='sim time', unit='sim s', position=1,
                  disable=disable, file=sys.stderr, bar_format=bar_format) as seconds:
            results = pool.imap_unordered(run_and_write, batches, chunksize=1)
            while len(ran) < len(pending):
                try:
                    done = results.next(timeout=0.5)
                except multiprocessing.TimeoutError:
                    if started.value > jobs:
                        raise StudyError('a worker process died (killed, or crashed: its '
                                         'output is above); the episodes it held are lost. '
                                         'Rerun the same command to resume') from None
                else:
                    for folder, wall, cpu in done:
                        ran[folder] = wall, cpu
                        progress.show_done(episodes, shown, len(ran), len(pending),
                                           folder, wall)
                seconds.update(min(counter.value, total) - seconds.n)
        pool.close()
    except Interrupted as stopped:  # Ctrl-C or SIGTERM (run_study's handlers): stop now
        stopped.announce()
        pool.terminate()
        stopped.ran = dict(ran)
        raise
    except BaseException:  # a failed episode, or Ctrl-C without them: stop every worker now
        pool.terminate()
        raise
    finally:
        pool.join()
    return ran
