"""The live view: an episode served to Foxglove over its WebSocket protocol, as it runs.

:class:`LiveServer` is a foxglove-sdk WebSocket server on localhost whose channels carry the
topics of the bags as raw CDR with their ROS 2 message definitions (``ros2msg`` schemas), so
Foxglove decodes them natively and what a user sees live is what a bag holds. Log times and
the server's time are sim time. Two feeders use it:

* :class:`LiveView`, an observer of the embedded runner (``mona-swarm run --live``); it also
  paces the episode to a multiple of real time on request (``--pace``);
* :mod:`swarm_supervisor.system.ros.live_node`, a node of the node system that forwards the
  recorded topics (``scripts/swarm.sh --live``).

Watching must not slow the episode down: messages are made only for channels a client
subscribes to (none connected: nothing is built), and at most ``rate`` times per wall second
(poses, robot markers and states, clock), :data:`SLOW_RATE` times (status, a metric sample)
or ``map_rate`` times (the cue map and grid, and only once the world would have published a
new one).

Before the episode, :meth:`LiveServer.wait_for_viewer` can hold its start until a client has
subscribed, so a viewer whose page takes long to load sees it from t = 0 (``mona-swarm run
--live --wait-for-viewer``). When the episode has ended, :meth:`LiveView.linger` keeps
serving its final state (repeated once a second for clients that connect then) until a
wall-clock limit or a stop, so a viewer is not cut off mid-look (``mona-swarm run --live
--linger``).
"""

from __future__ import annotations

import sys
import threading
import time
from collections.abc import Callable
from typing import cast

import foxglove
from foxglove import Channel, Schema
from foxglove.websocket import Capability

from mona_controller import topics
from mona_controller.contract import Announcement, Poses, WorldState, WorldStatus
from mona_controller.controllers import states_of
from mona_controller.topics import (
    CLOCK,
    CUE_GRID,
    CUE_MAP,
    EPISODE,
    MARKERS,
    OBSTACLES,
    POSES,
    ROBOT_STATES,
    SOURCES,
    STATUS,
    metric_topic,
)
from swarm_metrics.metrics import metric_names
from swarm_supervisor.engine.episode import Episode, Step
from swarm_supervisor.engine.runner import EpisodeObserver, Pacer
from swarm_supervisor.media import DEFAULT_PORT
from swarm_supervisor.media.relay import SDK_SUBPROTOCOL, Relay
from swarm_supervisor.outputs.bag import EMBEDDED_MODE
from swarm_world.messages.cdr import (
    TYPESTORE,
    clock_cdr,
    cue_grid_cdr,
    cue_image_cdr,
    float64_cdr,
    markers_cdr,
    obstacles_cdr,
    pose_array_cdr,
    sources_cdr,
    states_cdr,
    string_cdr,
)
from swarm_world.params import WorldNodeParams
from swarm_world.timing import crossed

#: Foxglove's WebSocket subprotocol as served by foxglove-sdk 0.30 (the relay in front of it
#: also accepts its older name, :data:`swarm_supervisor.media.relay.LEGACY_SUBPROTOCOL`).
SUBPROTOCOL = SDK_SUBPROTOCOL
#: Frequent messages (poses, markers, states, clock) per wall second, at most.
RATE = 10.0
#: Statuses and metric samples per wall second, at most.
SLOW_RATE = 4.0
#: Cue maps (image and grid) per wall second, at most.
MAP_RATE = 2.0
#: Steps between looks at the wall clock when not paced (8 steps: 0.26 s of sim time).
CHECK_EVERY = 8
#: Wall seconds between repeats of the announcement and the latest status, for late joiners.
REPEAT_PERIOD = 1.0
#: Wall seconds between looks for a subscribed client while the start is held.
VIEWER_POLL = 0.05


def live_topics() -> dict[str, str]:
    """Every topic the live view may carry, with its type: the contract's live topics
    (:func:`mona_controller.topics.live`: the bag's topics less the cleaning events, which the
    cue map shows, plus the cue grid and the robot markers, a 3D view of the cue and of the
    robots coloured by state, and the obstacles), one ``/metrics/<name>`` per metric of the
    table now."""
    return {name: topic.type
            for name, topic in topics.expand(topics.live(), metric_names()).items()}


def __getattr__(name: str) -> object:
    # LIVE_TOPICS reads as a constant but follows the metrics table.
    if name == 'LIVE_TOPICS':
        return live_topics()
    raise AttributeError(f'module {__name__!r} has no attribute {name!r}')


def schema_of(msgtype: str) -> Schema:
    """The ``ros2msg`` schema of a ROS 2 message type (its definition with dependencies)."""
    text, _ = TYPESTORE.generate_msgdef(msgtype, ros_version=2)
    return Schema(name=msgtype, encoding='ros2msg', data=text.encode())


class LiveServer:
    """A Foxglove WebSocket server on ``host:port`` with a channel per topic of
    :func:`live_topics` (raw CDR, ``ros2msg`` schemas) and sim time as its clock.

    Clients connect to a :class:`~swarm_supervisor.media.relay.Relay` on ``host:port``, which
    accepts both names of the subprotocol (``foxglove.sdk.v1`` and the older
    ``foxglove.websocket.v1``) and relays each client to the foxglove-sdk server, which
    listens on a free port of 127.0.0.1 (it accepts only the first name).

    Args:
        port: TCP port (0: any free one; :attr:`port` tells which).
        host: interface to listen on (localhost by default: nothing leaves the machine).
        topics: the topics to serve, with their types (default: all of :func:`live_topics`).

    Raises:
        RuntimeError: the server cannot listen there (the port is taken, ...).
    """

    def __init__(self, port: int = DEFAULT_PORT, host: str = '127.0.0.1',
                 topics: dict[str, str] | None = None) -> None:
        self.context = foxglove.Context()  # not the SDK's global one: two servers stay apart
        self.channels = {topic: Channel(topic, schema=schema_of(msgtype),
                                        message_encoding='cdr', context=self.context)
                         for topic, msgtype in (topics or live_topics()).items()}
        try:
            self.server = foxglove.start_server(name='mona-swarm', host='127.0.0.1', port=0,
                                                capabilities=[Capability.Time],
                                                context=self.context)
        except Exception as error:  # the SDK raises its own error types
            raise RuntimeError(f'the live view cannot start its server: {error}') from None
        try:
            self.relay = Relay(host, port, self.server.port)
        except RuntimeError as error:
            self.server.stop()
            raise RuntimeError(f'the live view cannot listen on {host}:{port}: '
                               f'{error}') from None
        self.host = host
        self.time_ns = 0

    @property
    def port(self) -> int:
        """The TCP port clients connect to (useful when 0 was asked for)."""
        return self.relay.port

    @property
    def url(self) -> str:
        """The WebSocket URL to open in Foxglove ("Open connection", Foxglove WebSocket)."""
        return f'ws://{self.host}:{self.port}'

    def wanted(self, topic: str) -> bool:
        """Whether a client subscribes to ``topic`` (else building its message is wasted)."""
        channel = self.channels.get(topic)
        return channel is not None and channel.has_sinks()

    def watched(self) -> bool:
        """Whether a client subscribes to any channel: a viewer is watching (a client that
        only connects, or only lists the channels, is not one)."""
        return any(channel.has_sinks() for channel in self.channels.values())

    def wait_for_viewer(self, timeout: float | None,
                        stop: threading.Event | None = None) -> bool:
        """Wait until a client subscribes to a channel (:meth:`watched`), at most ``timeout``
        wall seconds (None: no limit) or until ``stop`` is set; whether one did."""
        deadline = None if timeout is None else time.monotonic() + timeout
        stop = stop or threading.Event()
        while not self.watched():
            wait = VIEWER_POLL if deadline is None else \
                min(VIEWER_POLL, deadline - time.monotonic())
            if wait <= 0 or stop.wait(wait):
                return self.watched()
        return True

    def publish(self, topic: str, log_ns: int, data: bytes | Callable[[], bytes]) -> None:
        """Send a message (CDR bytes, or a function making them, called only if wanted)."""
        channel = self.channels.get(topic)
        if channel is not None and channel.has_sinks():
            channel.log(data if isinstance(data, bytes) else data(), log_time=log_ns)

    def set_time(self, time_ns: int) -> None:
        """The server's clock: sim time."""
        if time_ns != self.time_ns:
            self.time_ns = time_ns
            self.server.broadcast_time(time_ns)

    def stop(self) -> None:
        """Close every connection and stop listening."""
        self.relay.stop()
        self.server.stop()


class LiveView(EpisodeObserver):
    """Serves an embedded episode to Foxglove while it runs (an observer of run_episode).

    Args:
        server: where to publish.
        pace: run at this many sim seconds per wall second (None: as fast as possible).
        rate: frequent messages (poses, markers, states, clock) per wall second, at most.
        map_rate: cue maps per wall second, at most.
        start_ns: the sim time of the episode's t = 0.
    """

    def __init__(self, server: LiveServer, *, pace: float | None = None, rate: float = RATE,
                 map_rate: float = MAP_RATE, start_ns: int = 0) -> None:
        self.server = server
        self.pacer = None if pace is None else Pacer(pace)
        self.period = 1.0 / rate
        self.map_period = 1.0 / map_rate
        self.start_ns = start_ns
        self.announcement = b''
        self.obstacles = b''
        self.sources = b''  # the latest sources' markers sent, repeated for late joiners
        self.status = b''
        self.cleaning_events = 0
        self._next_frame = self._next_map = self._next_repeat = self._next_slow = 0.0
        self.slow_period = 1.0 / SLOW_RATE
        self._sample_due = True
        self._last_map_ns = -1  # the episode time of the last cue map sent
        #: Steps between looks at the wall clock (every step when paced: a slow episode).
        self.check_every = 1 if pace is not None else CHECK_EVERY
        self._countdown = 1
        # The world node's cue map period: a new map is worth sending once per period.
        self._map_ns = round(WorldNodeParams.map_period * 1e9)
        self.frames = 0  #: frequent-message rounds sent (for the benchmark)
        self._final: Episode | None = None  # the finished episode, for linger()

    # --- the observer ---------------------------------------------------------------------

    def start(self, episode: Episode) -> None:
        """Announce the episode to every client."""
        config = episode.config
        self.announcement = string_cdr(Announcement(
            0, seed=episode.seed, population=config.episode.population,
            duration=config.episode.duration, start_ns=self.start_ns,
            poses=cast(Poses, tuple(map(tuple, episode.initial_poses.tolist()))),
            parameters=config.to_dict(), plugins=tuple(config.plugin_records()),
            states=states_of(config.controller.kind)).to_json())
        self.obstacles = obstacles_cdr(episode.world.arena)
        if self.pacer is not None:
            self.pacer.start(episode)
        self._status(episode, WorldState.RUNNING)
        self._metrics(episode)
        self._frame(episode, time.perf_counter(), force=True)

    def step(self, episode: Episode, step: Step) -> None:
        """Send what changed, throttled to the wall clock."""
        # Called 10,000 times a wall second: the clock is read every few steps only, and
        # everything sent is throttled to the wall clock (bench/bench_live.py).
        if len(step.cleaned):
            self.cleaning_events += 1
        if step.sampled and self._sample_due:
            # A metric sample exactly as the bag has it, at most one per frame.
            self._sample_due = False
            self._metrics(episode)
        if self.pacer is not None:
            self.pacer.step(episode, step)
        self._countdown -= 1
        if self._countdown <= 0:
            self._countdown = self.check_every
            wall = time.perf_counter()
            if wall >= self._next_frame:
                self._frame(episode, wall)

    def finish(self, episode: Episode) -> None:
        """Send the last metrics, the finished status and a final frame."""
        self._metrics(episode)  # the last sample, whatever the throttle
        self._status(episode, WorldState.FINISHED)
        self._frame(episode, time.perf_counter(), force=True)
        self._final = episode

    def linger(self, seconds: float | None, stop: threading.Event | None = None) -> None:
        """After :meth:`finish`: keep serving the episode's final state, sent again every
        :data:`REPEAT_PERIOD` for clients that connect now, for ``seconds`` of wall time
        (None: until ``stop`` is set, or a KeyboardInterrupt)."""
        episode = self._final
        if episode is None:
            raise RuntimeError('linger() serves a finished episode: run it first')
        end = None if seconds is None else time.monotonic() + seconds
        stop = stop or threading.Event()
        while True:
            self._status(episode, WorldState.FINISHED)
            self._metrics(episode)
            self._frame(episode, time.perf_counter(), force=True)
            wait = REPEAT_PERIOD if end is None else min(REPEAT_PERIOD, end - time.monotonic())
            if wait <= 0 or stop.wait(wait):
                return

    # --- messages ---------------------------------------------------------------------------

    def _frame(self, episode: Episode, wall: float, force: bool = False) -> None:
        """The frequent messages, and the cue map when due; repeats for late joiners."""
        server, world = self.server, episode.world
        now_ns = self.start_ns + episode.time_ns
        self._next_frame = wall + self.period
        self.frames += 1
        server.set_time(now_ns)
        server.publish(CLOCK, now_ns, clock_cdr(now_ns))
        if wall >= self._next_slow:
            # The status and a metric sample: a few a second are plenty for plots and text.
            self._next_slow = wall + self.slow_period
            self._sample_due = True
            if not force:
                self._status(episode, WorldState.RUNNING)
        server.publish(POSES, now_ns, lambda: pose_array_cdr(world.poses, now_ns))
        states = episode.controllers.state
        server.publish(ROBOT_STATES, now_ns, lambda: states_cdr(states))
        server.publish(MARKERS, now_ns, lambda: markers_cdr(
            world.poses, states, episode.config.mona.body_radius, now_ns,
            palette=[state.colour for state in type(episode.controllers).STATES]))
        # A new map only once the world would have published one (every map_period).
        if force or (wall >= self._next_map and crossed(self._last_map_ns, episode.time_ns,
                                                        self._map_ns)):
            self._last_map_ns = episode.time_ns
            self._next_map = wall + self.map_period
            server.publish(CUE_MAP, now_ns, lambda: cue_image_cdr(world.cue, now_ns))
            server.publish(CUE_GRID, now_ns, lambda: cue_grid_cdr(
                world.cue, episode.config.world.cell_size, now_ns))
            if server.wanted(SOURCES):  # the world publishes the sources with the map
                field = world.field
                self.sources = sources_cdr(field.names,
                                           field.source_positions(episode.time_ns / 1e9), now_ns)
                server.publish(SOURCES, now_ns, self.sources)
        if force or wall >= self._next_repeat:
            # Topics Foxglove shows as state, sent again so a client that connects late has
            # them (the bags' latched topics: the announcement, the static obstacles).
            self._next_repeat = wall + REPEAT_PERIOD
            server.publish(EPISODE, self.start_ns, self.announcement)
            server.publish(OBSTACLES, self.start_ns, self.obstacles)  # as the bag has it
            if self.sources:
                server.publish(SOURCES, now_ns, self.sources)

    def _status(self, episode: Episode, state: WorldState) -> None:
        if not self.server.wanted(STATUS):
            return
        now_ns = self.start_ns + episode.time_ns
        self.status = string_cdr(WorldStatus(
            0, state, step=episode.steps_done, steps=episode.steps_total, time_ns=now_ns,
            mode=EMBEDDED_MODE, misses=(0,) * episode.config.episode.population,
            cleaning_events=self.cleaning_events).to_json())
        self.server.publish(STATUS, now_ns, self.status)

    def _metrics(self, episode: Episode) -> None:
        """The metric sample of now, as /metrics/<name> (only if a client plots them)."""
        names = metric_names()
        topics = [metric_topic(name) for name in names]
        if not any(self.server.wanted(topic) for topic in topics):
            return
        row = episode.metrics()
        log_ns = self.start_ns + round(row['t'] * 1e9)
        for name, topic in zip(names, topics):
            self.server.publish(topic, log_ns, float64_cdr(float(row[name])))


def announce(server: LiveServer, what: str) -> None:
    """Tell the user where to point Foxglove (stderr, one line)."""
    print(f'{what}: live view on {server.url} (Foxglove: Open connection, Foxglove '
          f'WebSocket; layout: ros_ws/config/foxglove_layout.json)', file=sys.stderr, flush=True)
