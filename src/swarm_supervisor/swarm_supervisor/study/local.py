"""The study's episodes on local worker processes (a multiprocessing pool)."""

from __future__ import annotations

import multiprocessing
import os
import queue
import sys
from collections.abc import Sequence

from tqdm import tqdm

from swarm_supervisor.study import progress
from swarm_supervisor.study.interrupt import Interrupted, StopRequest
from swarm_supervisor.study.tasks import EpisodeTask, run_and_write


def available_cpus() -> int:
    """The CPUs this process may use."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def run_local(batches: Sequence[Sequence[EpisodeTask]], jobs: int, shown: bool | None,
              start_method: str = 'spawn') -> dict[str, tuple[float, float]]:
    """Run the batches of tasks (:func:`~swarm_supervisor.study.tasks.make_batches`) over a
    pool of ``jobs`` processes, with progress bars (``shown``: True, False, or None for only
    on a terminal).

    A batch is handed to a worker only when one is free, so a stop request
    (:mod:`~swarm_supervisor.study.interrupt`) can start no more: the first Ctrl-C lets the
    running batches finish, a second one or SIGTERM terminates every worker at once. A
    failed episode terminates them too. The episodes written by then stay on disk.

    Returns:
        folder -> (wall seconds, CPU seconds) of each episode (its share of its batch's),
        writing included.

    Raises:
        Interrupted: stopped by a signal; its ``ran`` holds the episodes finished before.
    """
    pending = [task for batch in batches for task in batch]
    if not pending:
        return {}
    context = multiprocessing.get_context(start_method)
    counter = context.Value('d', 0.0)
    total = sum(task.config.episode.duration for task in pending)
    ran: dict[str, tuple[float, float]] = {}
    waiting = list(batches)
    running: list[Sequence[EpisodeTask]] = []
    answers: queue.SimpleQueue = queue.SimpleQueue()  # (batch, result or exception)

    def described() -> str:
        return (f'{len(running)} running batch{"es" if len(running) != 1 else ""} '
                f'({sum(map(len, running))} episodes)')

    pool = context.Pool(jobs, initializer=progress.init_worker, initargs=(counter,))
    bar_format = '{desc}: {percentage:3.0f}%|{bar}| {n:.0f}/{total:.0f} {unit} ' \
                 '[{elapsed}<{remaining}]'
    disable = None if shown is None else not shown
    try:
        with StopRequest(running=described) as stop, \
             tqdm(total=len(pending), desc='episodes', unit='episodes', position=0,
                  disable=disable, file=sys.stderr, bar_format=bar_format) as episodes, \
             tqdm(total=total, desc='sim time', unit='sim s', position=1,
                  disable=disable, file=sys.stderr, bar_format=bar_format) as seconds:
            while running or (waiting and stop.requested is None):
                while waiting and len(running) < jobs and stop.requested is None:
                    batch = waiting.pop(0)
                    running.append(batch)
                    pool.apply_async(run_and_write, (batch,),
                                     callback=lambda done, b=batch: answers.put((b, done)),
                                     error_callback=lambda e, b=batch: answers.put((b, e)))
                try:
                    batch, done = answers.get(timeout=0.5)
                except queue.Empty:
                    pass
                else:
                    running.remove(batch)
                    if isinstance(done, BaseException):
                        raise done
                    for folder, wall, cpu in done:
                        ran[folder] = wall, cpu
                        progress.show_done(episodes, shown, len(ran), len(pending), folder,
                                           wall)
                seconds.update(min(counter.value, total) - seconds.n)
            stop.check(ran)  # the first Ctrl-C: the running batches are done, stop here
        pool.close()
    except Interrupted as stopped:
        pool.terminate()
        stopped.ran = dict(ran)
        raise
    except BaseException:  # a failed episode (or Ctrl-C outside the handlers): stop now
        pool.terminate()
        raise
    finally:
        pool.join()
    return ran
