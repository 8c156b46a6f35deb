"""The embedded runner: the world and every controller stepped in one process, as fast as the
machine allows. It runs the study, sweeps and tests; the ROS node system runs the same core."""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Sequence
from typing import Protocol

import numpy as np

from swarm_supervisor.config import SwarmConfig
from swarm_supervisor.episode import Episode, Step


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
        self.started = time.perf_counter()

    def step(self, episode: Episode, step: Step) -> None:
        ahead = step.time_ns / 1e9 / self.pace - (time.perf_counter() - self.started)
        if ahead > 0.002:  # sleep in slices the OS honours
            time.sleep(ahead)

    def finish(self, episode: Episode) -> None:
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
    world = episode.world
    pending = sorted(snapshot_times)
    snapshots: dict[float, tuple[np.ndarray, np.ndarray]] = {}
    rows: list[dict[str, float]] = []

    def record() -> None:
        rows.append(episode.metrics())
        t = rows[-1]['t']
        while pending and pending[0] <= t + 1e-9:
            snapshots[pending.pop(0)] = (world.cue.copy(), world.poses.copy())
        if progress is not None:
            progress(t)

    record()
    for observer in observers:
        observer.start(episode)
    while not episode.done:
        step = episode.step()
        if step.sampled:
            record()
        for observer in observers:
            observer.step(episode, step)
    for observer in observers:
        observer.finish(episode)
    return EpisodeResult(
        config=config, metrics=rows, initial_poses=episode.initial_poses,
        final_poses=world.poses.copy(), final_cue=world.cue.copy(), snapshots=snapshots,
        encounters=int(episode.controllers.encounters.sum()), steps=episode.steps_done,
        wall_time=time.perf_counter() - started)
