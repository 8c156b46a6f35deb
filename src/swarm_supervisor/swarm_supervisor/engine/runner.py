"""The embedded runner: the world and every controller stepped in one process, as fast as the
machine allows. It runs the study, sweeps and tests; the ROS node system runs the same core."""

from __future__ import annotations

import dataclasses
import functools
import time
from collections.abc import Callable, Sequence
from typing import Protocol, cast

import numpy as np

from swarm_supervisor.config import SwarmConfig
from swarm_supervisor.engine.batch import Batch
from swarm_supervisor.engine.episode import Episode, Step


class EpisodeObserver(Protocol):
    """Something that watches an episode as it runs (a bag recorder, the live view)."""

    def start(self, episode: Episode) -> None:
        """The episode is placed, nothing has stepped yet."""

    def step(self, episode: Episode, step: Step) -> None:
        """One step is done (``episode`` shows the state after it)."""

    def finish(self, episode: Episode) -> None:
        """The episode ran its duration."""


class Pacer:
    """An observer that holds the episode to ``pace`` sim seconds per wall second (so a person
    can follow it, e.g. in the live view)."""

    def __init__(self, pace: float) -> None:
        self.pace = pace
        self.started = time.perf_counter()

    def start(self, episode: Episode) -> None:
        """Note the wall clock at sim time 0."""
        self.started = time.perf_counter()

    def step(self, episode: Episode, step: Step) -> None:
        """Sleep until the wall clock catches up with ``pace`` times the sim clock."""
        ahead = step.time_ns / 1e9 / self.pace - (time.perf_counter() - self.started)
        if ahead > 0.002:  # sleep in slices the OS honours
            time.sleep(ahead)

    def finish(self, episode: Episode) -> None:
        """Nothing to close."""
        pass


@dataclasses.dataclass
class EpisodeResult:
    """Everything one episode produced."""

    config: SwarmConfig
    metrics: list[dict[str, float]]  #: one row per sample period, from t = 0
    initial_poses: np.ndarray
    final_poses: np.ndarray
    final_cue: np.ndarray
    snapshots: dict[float, tuple[np.ndarray, np.ndarray]]  #: t -> (cue, poses)
    encounters: int  #: robot-robot encounters that started a wait
    steps: int
    wall_time: float  #: seconds

    @property
    def real_time_factor(self) -> float:
        """Simulated seconds per wall-clock second."""
        return self.steps * self.config.world.step_period / max(self.wall_time, 1e-9)


class _Collector:
    """One episode's metrics rows and snapshots as it runs (the lone and the batched runner
    record an episode alike)."""

    def __init__(self, episode: Episode, snapshot_times: Sequence[float],
                 progress: Callable[[float], None] | None) -> None:
        self.episode = episode
        self.pending = sorted(snapshot_times)
        self.snapshots: dict[float, tuple[np.ndarray, np.ndarray]] = {}
        self.rows: list[dict[str, float]] = []
        self.progress = progress

    def record(self) -> None:
        """A metrics row now, and the snapshots due by its time."""
        world = self.episode.world
        self.rows.append(self.episode.metrics())
        t = self.rows[-1]['t']
        while self.pending and self.pending[0] <= t + 1e-9:
            self.snapshots[self.pending.pop(0)] = (world.cue.copy(), world.poses.copy())
        if self.progress is not None:
            self.progress(t)

    def result(self, wall_time: float) -> EpisodeResult:
        episode, world = self.episode, self.episode.world
        return EpisodeResult(
            config=episode.config, metrics=self.rows, initial_poses=episode.initial_poses,
            final_poses=world.poses.copy(), final_cue=world.cue.copy(),
            snapshots=self.snapshots, encounters=int(episode.controllers.encounters.sum()),
            steps=episode.steps_done, wall_time=wall_time)


def run_episode(config: SwarmConfig, *, snapshot_times: Sequence[float] = (),
                progress: Callable[[float], None] | None = None,
                observers: Sequence[EpisodeObserver] = ()) -> EpisodeResult:
    """Run one episode of ``config.episode`` and collect its metrics.

    Args:
        snapshot_times: sim times (s) at which to keep a copy of the cue map and the poses;
            each is taken at the first metrics sample at or after it.
        progress: called with the sim time after each metrics sample.
        observers: told of the start, of every step and of the end (in this order).
    """
    started = time.perf_counter()
    episode = Episode(config)
    collector = _Collector(episode, snapshot_times, progress)
    collector.record()
    for observer in observers:
        observer.start(episode)
    while not episode.done:
        step = episode.step()
        if step.sampled:
            collector.record()
        for observer in observers:
            observer.step(episode, step)
    for observer in observers:
        observer.finish(episode)
    return collector.result(time.perf_counter() - started)


def run_batch(configs: Sequence[SwarmConfig], *, snapshot_times: Sequence[float] = (),
              progress: Callable[[int, float], None] | None = None,
              observers: Sequence[Sequence[EpisodeObserver]] | None = None,
              finished: Callable[[int, EpisodeResult], None] | None = None
              ) -> list[EpisodeResult]:
    """Run the episodes of ``configs`` together (:class:`~swarm_supervisor.engine.Batch`);
    each result equals :func:`run_episode`'s for that config, except the timing.

    Args:
        configs: one per episode; they must share :func:`~swarm_supervisor.engine.batch_key`.
        snapshot_times: as :func:`run_episode`, for every episode.
        progress: called with (episode index, sim time) after each of its metrics samples.
        observers: per episode (same length as ``configs``), as :func:`run_episode`'s.
        finished: called with (episode index, result) as soon as that episode is done (its
            observers finished), e.g. to write its outputs before the others end.

    Returns:
        The results in the order of ``configs``. An episode's ``wall_time`` is its share of
        the batch's: the wall time until it finished divided by the batch's size (so its
        ``real_time_factor`` is the per-episode factor of the batch).

    Raises:
        BatchError: the configs differ in step or control period or IR beams.
    """
    started = time.perf_counter()
    observers = observers if observers is not None else [()] * len(configs)
    episodes = [Episode(config) for config in configs]
    index = {id(episode): k for k, episode in enumerate(episodes)}
    collectors = [_Collector(episode, snapshot_times,
                             None if progress is None else functools.partial(progress, k))
                  for k, episode in enumerate(episodes)]
    results: list[EpisodeResult | None] = [None] * len(configs)

    def finish(k: int) -> None:
        for observer in observers[k]:
            observer.finish(episodes[k])
        result = collectors[k].result((time.perf_counter() - started) / len(configs))
        results[k] = result
        if finished is not None:
            finished(k, result)

    batch = Batch(episodes)
    for k, episode in enumerate(episodes):
        collectors[k].record()
        for observer in observers[k]:
            observer.start(episode)
        if episode.done:  # zero steps
            finish(k)
    while not batch.done:
        for episode, step in batch.step():
            k = index[id(episode)]
            if step.sampled:
                collectors[k].record()
            for observer in observers[k]:
                observer.step(episode, step)
            if episode.done:
                finish(k)
    return cast(list[EpisodeResult], results)  # every episode finished
