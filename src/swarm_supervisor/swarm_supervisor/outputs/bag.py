"""The embedded runner's bag: the record the metrics node writes, from an in-process episode.

:class:`BagRecorder` watches an embedded episode (an observer of
:func:`~swarm_supervisor.engine.run_episode`), makes the messages the world node and the
supervisor would publish for it (:mod:`swarm_world.messages.cdr`), in the order they publish
them, and feeds them to the metrics node's own recording logic,
:class:`swarm_metrics.bags.recording.Recorder`. So the embedded bag has the node system's topics,
types, QoS metadata, custom_data and sampling, by construction; ``analyze``, ``replay``,
``animate`` and Foxglove read either runner's bags alike, down to the robots' controller
states and the sources' markers.

For the study, :func:`record_episode` runs one episode and writes its bag.
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import cast

import numpy as np
from rosbags.interfaces import Qos

from mona_controller import topics
from mona_controller.contract import Announcement, Poses, WorldState, WorldStatus
from mona_controller.controllers import states_of
from mona_controller.topics import CLEANING, CLOCK, CUE_MAP, POSES
from swarm_metrics.bags.record import Closed
from swarm_metrics.bags.recording import Recorder
from swarm_metrics.bags.writer import CHUNK_PERIOD, bag_topics
from swarm_metrics.metrics import metric_names
from swarm_supervisor.config import SwarmConfig
from swarm_supervisor.engine.episode import Episode, Step
from swarm_supervisor.engine.runner import EpisodeObserver, EpisodeResult, run_episode
from swarm_world.messages.cdr import (
    clock_cdr,
    cue_image_cdr,
    obstacles_cdr,
    pose_array_cdr,
    sources_cdr,
    states_cdr,
    string_cdr,
)
from swarm_world.params import WorldNodeParams
from swarm_world.timing import crossed

#: The status ``mode`` of an embedded episode (the world node says lockstep or realtime).
EMBEDDED_MODE = 'embedded'


def bag_topic_table() -> dict[str, tuple[str, Qos]]:
    """Every topic an embedded bag holds, with its type and offered QoS: the contract's
    recorded topics (:func:`mona_controller.topics.recorded`), one ``/metrics/<name>`` per
    metric of the table now. The node system's bags hold the same."""
    return bag_topics(topics.expand(topics.recorded(), metric_names()))


def __getattr__(name: str) -> object:
    # TOPICS reads as a constant but follows the metrics table (a metric registered after
    # this module was imported is in it too).
    if name == 'TOPICS':
        return bag_topic_table()
    raise AttributeError(f'module {__name__!r} has no attribute {name!r}')


def status_json(status: WorldStatus) -> str:
    """``status.to_json()``, without ``dataclasses.asdict``'s deep copy (a third of a
    millisecond for 50 robots' misses, once per sim second)."""
    document = {field.name: getattr(status, field.name)
                for field in dataclasses.fields(status)}
    document.update(state=status.state.value, misses=list(status.misses),
                    absent=list(status.absent))
    return json.dumps(document)


class RecordError(RuntimeError):
    """An embedded episode's bag is incomplete, or its metrics differ from the runner's."""


@dataclasses.dataclass(frozen=True)
class BagOptions:
    """How the bag is recorded: the metrics node's and the world node's defaults."""

    chunk_period: float = CHUNK_PERIOD  #: sim s per chunk
    cue_map_period: float = 10.0  #: record /world/cue_map at most this often (sim s)
    clock_period: float = WorldNodeParams.clock_period  #: /clock period (sim s)
    map_period: float = WorldNodeParams.map_period  #: the world's cue map period (sim s)
    status_period: float = WorldNodeParams.status_period  #: the world's status period (sim s)


class _FolderRecorder(Recorder):
    """A Recorder whose one episode goes to ``<folder>/bag``."""

    def __init__(self, folder: Path, options: BagOptions) -> None:
        super().__init__(folder, chunk_period=options.chunk_period,
                         cue_map_period=options.cue_map_period,
                         clock_period=options.clock_period)

    def episode_folder(self, episode: int) -> Path:
        return self.output_dir


class BagRecorder(EpisodeObserver):
    """Records one embedded episode into ``<folder>/bag`` as the metrics node would.

    Args:
        folder: the episode folder; the bag becomes ``<folder>/bag`` (which must not exist).
        episode: the episode number announced (``episode_<k>`` in the node system).
        start_ns: the sim time of the episode's t = 0.
        options: recording periods (default: the nodes' defaults).

    After the run, :attr:`closed` is the closed record and :attr:`rows` the metric samples
    the recorder computed (the metrics node's online metrics).

    Raises:
        FileExistsError: ``<folder>/bag`` exists (a bag is never overwritten).
    """

    def __init__(self, folder: str | Path, *, episode: int = 0, start_ns: int = 0,
                 options: BagOptions = BagOptions()) -> None:
        self.folder = Path(folder)
        self.path = self.folder / 'bag'
        if self.path.exists():
            raise FileExistsError(f'{self.path} exists: a bag is never overwritten; remove it '
                                  'or choose another folder')
        self.options = options
        self.episode_number = episode
        self.start_ns = start_ns
        self.recorder = _FolderRecorder(self.folder, options)
        self.rows: list[dict[str, float]] = []
        self.closed: Closed | None = None
        self._cleaning_events = 0
        self._periods = {name: round(getattr(options, name) * 1e9)
                         for name in ('clock_period', 'map_period', 'status_period')}

    # --- what the world and the supervisor would publish ---------------------------------

    def start(self, episode: Episode) -> None:
        """Write the announcement, the static topics and the first state."""
        config, world = episode.config, episode.world
        announcement = Announcement(
            self.episode_number, seed=episode.seed, population=config.episode.population,
            duration=config.episode.duration, start_ns=self.start_ns,
            poses=cast(Poses, tuple(map(tuple, episode.initial_poses.tolist()))),
            parameters=config.to_dict(), plugins=tuple(config.plugin_records()),
            states=states_of(config.controller.kind))
        try:
            # The world node's latched scenery reaches the metrics node before any episode.
            self.recorder.obstacles(obstacles_cdr(world.arena))
            self._take(self.recorder.announce(string_cdr(announcement.to_json())).rows)
            self._status(episode, WorldState.WAITING)
            self.recorder.periodic(CLOCK, clock_cdr(self.start_ns))
            self._map(episode, self.start_ns)
            self._status(episode, WorldState.RUNNING)
            self._poses(episode, self.start_ns)
        except BaseException:
            self.recorder.close()
            raise

    def step(self, episode: Episode, step: Step) -> None:
        """Record the step's messages (the bag is closed on any error, so it stays readable)."""
        try:
            self._step(episode, step)
        except BaseException:
            self.recorder.close()
            raise

    def _step(self, episode: Episode, step: Step) -> None:
        # The world node's order: cleaning, clock, cue map, status after the step; the poses
        # come with the next step's readings (the last step's with the end, in finish()).
        world = episode.world
        before, now = self.start_ns + step.before_ns, self.start_ns + step.time_ns
        if len(step.cleaned):
            self._cleaning_events += 1
            self._route(CLEANING, pose_array_cdr(world.poses[step.cleaned], now))
        if crossed(before, now, self._periods['clock_period']):
            self.recorder.periodic(CLOCK, clock_cdr(now))
        # After the last step the world at once publishes the end's cue map and status, with
        # the same stamp, on latched keep-last-1 topics: those replace the last step's, which
        # the metrics node may or may not see (it records one map per instant). So they are
        # left out here.
        last = episode.done
        if not last and crossed(step.before_ns, step.time_ns, self._periods['map_period']):
            self._map(episode, now)
        if not last and crossed(step.before_ns, step.time_ns, self._periods['status_period']):
            self._status(episode, WorldState.RUNNING)
        # The world publishes the poses of every step; the recorder keeps only those of the
        # sample times, so only those are made (the rest would be dropped unread).
        if step.sampled and not episode.done:
            self._poses(episode, now)

    def finish(self, episode: Episode) -> None:
        """Write the last cue map, metrics and status, then close the bag."""
        try:
            now = self.start_ns + episode.time_ns
            self._map(episode, now)
            self._poses(episode, now)
            self._status(episode, WorldState.FINISHED)
        finally:
            closed, rows = self.recorder.close()
            self._take(rows)
            self.closed = closed

    # --- into the recorder -----------------------------------------------------------------

    def _route(self, topic: str, data: bytes) -> None:
        self._take(self.recorder.route(topic, data))

    def _map(self, episode: Episode, now: int) -> None:
        """The world node's publish_map: the cue map, then the sources (the grid and the
        markers are not recorded)."""
        field = episode.world.field
        self._route(CUE_MAP, cue_image_cdr(field.cue, now))
        self.recorder.sources(sources_cdr(field.names,
                                          field.source_positions(episode.world.time_ns / 1e9),
                                          now))

    def _poses(self, episode: Episode, now: int) -> None:
        # The world node's order: the controllers' states, then the poses they go with.
        self.recorder.robot_states(states_cdr(episode.controllers.state))
        self._route(POSES, pose_array_cdr(episode.world.poses, now))

    def _status(self, episode: Episode, state: WorldState) -> None:
        n = episode.config.episode.population
        status = WorldStatus(self.episode_number, state, step=episode.steps_done,
                             steps=episode.steps_total,
                             time_ns=self.start_ns + episode.time_ns, mode=EMBEDDED_MODE,
                             misses=(0,) * n, cleaning_events=self._cleaning_events)
        self._take(self.recorder.status(string_cdr(status_json(status)))[1])

    def _take(self, rows: list[tuple[int, dict[str, float]]]) -> None:
        self.rows += [row for _, row in rows]

    # --- the verdict -----------------------------------------------------------------------

    def check(self, result: EpisodeResult) -> Closed:
        """The closed record, once it is complete and its metrics equal the runner's.

        Raises:
            RecordError: naming what the bag lacks or where its metrics differ.
        """
        closed = self.closed
        if closed is None:
            raise RecordError(f'{self.path}: the episode never finished, the bag is incomplete')
        if not closed.complete:  # the completeness verdict on the bag (Recorder.close)
            raise RecordError(f'{closed.path} is incomplete: {"; ".join(closed.problems)}')
        if len(self.rows) != len(result.metrics):
            raise RecordError(f'{closed.path} holds {len(self.rows)} metric samples, the '
                              f'episode {len(result.metrics)}')
        for mine, theirs in zip(self.rows, result.metrics):
            differ = [key for key in theirs
                      if not (mine[key] == theirs[key]
                              or (np.isnan(mine[key]) and np.isnan(theirs[key])))]
            if differ:
                raise RecordError(f'{closed.path}: the recorded {differ[0]} at t = '
                                  f'{theirs["t"]:g} s is {mine[differ[0]]!r}, the runner has '
                                  f'{theirs[differ[0]]!r}')
        return closed


def record_episode(config: SwarmConfig, folder: str | Path, *,
                   snapshot_times: Sequence[float] = (),
                   progress: Callable[[float], None] | None = None,
                   observers: Sequence[EpisodeObserver] = (),
                   options: BagOptions = BagOptions()) -> tuple[EpisodeResult, Closed]:
    """Run one embedded episode of ``config`` and record its bag into ``<folder>/bag``.

    The same as :func:`~swarm_supervisor.engine.run_episode` (same arguments, same result),
    plus the bag the metrics node would have written for it.

    Returns:
        (the episode's result, its closed record: ``.path`` is the bag directory).

    Raises:
        FileExistsError: ``<folder>/bag`` exists.
        RecordError: the bag is incomplete or its metrics differ from the runner's (a bug).
    """
    recorder = BagRecorder(folder, options=options)
    result = run_episode(config, snapshot_times=snapshot_times, progress=progress,
                         observers=[recorder, *observers])
    return result, recorder.check(result)
