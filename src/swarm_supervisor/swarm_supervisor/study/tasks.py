"""What a study hands a worker: episode tasks, grouped into batches, run and written.

An :class:`EpisodeTask` is one episode of the design with where it goes. A worker (a local
process, :mod:`~swarm_supervisor.study.local`, or a Dask worker,
:mod:`~swarm_supervisor.study.cluster`) runs a batch of them with :func:`run_and_write`, which
steps them together (the batched engine) and writes each one's folder as soon as it is done;
only small tuples come back.
"""

from __future__ import annotations

import dataclasses
import os
import shutil
import time
import traceback
from collections.abc import Sequence
from pathlib import Path

from mona_controller import plugins
from swarm_supervisor import outputs
from swarm_supervisor.config import SwarmConfig
from swarm_supervisor.engine import batch_key, run_batch
from swarm_supervisor.study import progress
from swarm_supervisor.study.errors import EpisodeFailed

BAG_DIR = 'bag'  #: an episode's bag, inside its folder (``study --bag``)


@dataclasses.dataclass(frozen=True)
class EpisodeTask:
    """One episode to run and write (picklable: it travels to worker processes)."""

    config: SwarmConfig  #: every parameter of the episode
    snapshot_times: tuple[float, ...]  #: when to keep cue maps (s)
    folder: str  #: the episode folder to write
    bag: bool = False  #: also record its bag into ``<folder>/bag``
    picture: bool = True  #: also draw its final cue map (off: a calibration's screening)

    @property
    def cost(self) -> float:
        """The episode's cost, roughly: robot-seconds."""
        return max(self.config.episode.population, 1) * self.config.episode.duration


#: What a worker returns per task: (folder, wall s, CPU s), its share of its batch's times.
Ran = tuple[str, float, float]


def run_and_write(tasks: Sequence[EpisodeTask]) -> list[Ran]:
    """Run the episodes of ``tasks`` as one batch (:func:`~swarm_supervisor.engine.run_batch`;
    they share the snapshot times) and write each one's folder as soon as it is done, so an
    interrupted batch loses only its unfinished episodes.

    Returns:
        (folder, wall s, CPU s) per task: each episode's share of the batch's times, writing
        included.

    Raises:
        EpisodeFailed: an episode raised, or a plug-in of theirs could not be loaded as the
            study loaded it; the message names the batch's episodes and holds the traceback
            (which does not survive the trip to the parent otherwise).
    """
    started, cpu = time.perf_counter(), time.process_time()
    reported = [0.0] * len(tasks)
    names = ', '.join(task.folder for task in tasks)

    def sampled(k: int, t: float) -> None:
        if t - reported[k] >= progress.PROGRESS_STEP:
            progress.report(t - reported[k])
            reported[k] = t

    partials = [partial_folder(task.folder) for task in tasks]
    try:
        for task in tasks:  # the very plug-in code the study loaded, before any episode
            plugins.ensure(task.config.plugins)
        for partial in partials:  # left by a worker that was stopped mid-episode
            shutil.rmtree(partial, ignore_errors=True)
        recorders: list = [None] * len(tasks)
        if any(task.bag for task in tasks):
            from swarm_supervisor.outputs.bag import BagRecorder  # the bag's libraries, if asked
            for k, task in enumerate(tasks):
                if task.bag:
                    partials[k].mkdir(parents=True, exist_ok=True)
                    recorders[k] = BagRecorder(str(partials[k]))

        def finished(k: int, result) -> None:
            extra = None
            if recorders[k] is not None:
                recorders[k].check(result)
                extra = {'bag': BAG_DIR}
            progress.report(tasks[k].config.episode.duration - reported[k])
            outputs.write_episode(result, partials[k], extra=extra, picture=tasks[k].picture)
            move_into_place(partials[k], tasks[k].folder)

        run_batch([task.config for task in tasks], snapshot_times=tasks[0].snapshot_times,
                  progress=sampled, observers=[[] if r is None else [r] for r in recorders],
                  finished=finished)
    except Exception:
        raise EpisodeFailed(f'episode {names} failed:\n{traceback.format_exc()}') from None
    share = len(tasks)
    return [(task.folder, (time.perf_counter() - started) / share,
             (time.process_time() - cpu) / share) for task in tasks]


def partial_folder(folder: str | Path) -> Path:
    """Where an episode is written before it is moved to ``folder``: a hidden sibling, on the
    same filesystem, so the move is one rename."""
    folder = Path(folder)
    return folder.parent / f'.{folder.name}.partial'


def move_into_place(partial: Path, folder: str | Path) -> None:
    """Replace ``folder`` by the finished ``partial`` folder (one rename), so an episode
    folder is whole or absent whenever the process stops, and never lacks episode.json.

    An older ``folder`` (half-written by an earlier version, or complete but without the
    bag now asked for) is deleted first: for that instant the episode is absent, and a
    study stopped then simply runs it again.
    """
    target = Path(folder)
    if target.exists():
        shutil.rmtree(target)
    os.replace(partial, target)


def make_batches(pending: Sequence[EpisodeTask], batch_size: int,
                 jobs: int) -> list[tuple[EpisodeTask, ...]]:
    """Group the tasks into batches of at most ``batch_size`` that can be stepped together
    (:func:`~swarm_supervisor.engine.batch_key`), at least ``jobs`` batches when there are that
    many episodes (every worker gets work), the costliest first.

    Within a group, episodes are dealt out in turn, costliest first, so the batches of a
    group cost about the same and the workers finish together.
    """
    groups: dict[tuple, list[EpisodeTask]] = {}
    for task in pending:
        groups.setdefault(batch_key(task.config), []).append(task)
    batches: list[tuple[EpisodeTask, ...]] = []
    for tasks in groups.values():
        tasks = sorted(tasks, key=lambda task: -task.cost)
        count = max(-(-len(tasks) // batch_size), min(jobs, len(tasks)))
        batches += [tuple(tasks[k::count]) for k in range(count)]
    return sorted(batches, key=lambda batch: -sum(task.cost for task in batch))
