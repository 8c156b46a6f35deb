"""Recording episodes: the metrics node's logic, without ROS.

A :class:`Recorder` takes the messages of the world and the supervisor as the CDR bytes that
arrived, keeps one bag per announced episode (:class:`~swarm_metrics.bags.writer.
EpisodeBagWriter`), drives the :class:`~swarm_metrics.bags.analysis.MetricsReplica` that computes
the metrics online, and knows when its record of an episode is whole: it has the world's
final status and everything that status counts (the poses up to its time, its
``cleaning_events``), and a metric sample for every sample period from t = 0. Whether the
closed record is complete is not its own opinion: :meth:`Recorder.close` reads the bag back
and judges it with :func:`swarm_metrics.bags.completeness.check_bag`, the function every consumer
of a bag uses. The node (:mod:`swarm_metrics.ros.metrics_node`) subscribes, calls it, and
publishes what it returns.

The start of an episode is recorded before the world steps: the world publishes t = 0's cue
map, sources, states and poses, then holds its first step until every recorder's
``recorded_ns`` reaches ``start_ns`` (docs/interfaces.md, "Recorders"), which
:attr:`~swarm_metrics.bags.record.EpisodeRecord.recorded_ns` does only once those are in the
bag. What the recorder knows of the episode it records (and how it pairs the robots' states
with the poses) is :mod:`swarm_metrics.bags.record`.
"""

from __future__ import annotations

import bisect
import collections
from pathlib import Path
from typing import Any, cast

from mona_controller.contract import ContractError, WorldState, WorldStatus
from mona_controller.topics import (
    CLEANING,
    CLOCK,
    CUE_MAP,
    EPISODE,
    OBSTACLES,
    POSES,
    ROBOT_STATES,
    SOURCES,
    STATUS,
    TOPICS,
    metric_topic,
    topic_of,
)
from swarm_metrics.bags.analysis import NEVER, AnnouncementError, EpisodeSetup, MetricsReplica
from swarm_metrics.bags.completeness import check_bag_file
from swarm_metrics.bags.reader import decode, decode_json, poses_of
from swarm_metrics.bags.record import Announced, Closed, EpisodeRecord, Row
from swarm_metrics.bags.scan import BagError, RawMessage
from swarm_metrics.bags.writer import EpisodeBagWriter, offered
from swarm_metrics.metrics import metric_names
from swarm_world.messages.cdr import float64_cdr, markers_stamp_ns, stamp_ns

STRING, POSE_ARRAY = TOPICS[EPISODE].type, TOPICS[POSES].type
#: Messages of an episode not yet announced that are kept for its bag (see Recorder.route).
EARLY_LIMIT = 20_000


class Recorder:
    """One bag per announced episode, with the metrics computed online.

    Each topic is recorded with its type and offered QoS from the contract's table
    (:data:`mona_controller.topics.TOPICS`), each metric of the metrics table on
    ``/metrics/<name>``.

    Args:
        output_dir: episode k's bag goes to ``<output_dir>/episode_<k>/bag`` (``bag_1``, ...
            if that exists: a rerun never overwrites a bag).
        chunk_period: sim seconds per bag chunk.
        cue_map_period: record /world/cue_map at most this often (sim s; 0: every map).
        clock_period: record /clock at most this often (sim s; 0: every tick).
        record_all: record every message routed here, not just the sampled or periodic ones.
    """

    def __init__(self, output_dir: Path, *, chunk_period: float, cue_map_period: float,
                 clock_period: float, record_all: bool = False) -> None:
        self.output_dir = output_dir
        self.chunk_period = chunk_period
        # The sources are recorded as often as the cue map they explain.
        self.periods_ns = {CUE_MAP: round(cue_map_period * 1e9),
                           SOURCES: round(cue_map_period * 1e9),
                           CLOCK: round(clock_period * 1e9)}
        self.record_all = record_all
        self.episode: EpisodeRecord | None = None
        self.now_ns = 0  #: the latest sim time seen, for messages without a stamp
        self.early_lost = 0  #: early messages dropped because EARLY_LIMIT was reached
        self._closed_end_ns = -1  # older messages belong to no episode still to come
        self._early: collections.deque[tuple[str, bytes]] = collections.deque()
        self._last_recorded: dict[str, int] = {}  # of the periodic topics
        self._early_status: tuple[WorldStatus, bytes] | None = None
        self._obstacles: bytes | None = None  # the world's latest /world/obstacles

    @property
    def _current(self) -> EpisodeRecord:
        """The open episode: the private steps below run only while one is open."""
        return cast(EpisodeRecord, self.episode)

    # --- episodes -------------------------------------------------------------------

    def announce(self, data: bytes) -> Announced:
        """An /episode message: open the announced episode's bag.

        Raises:
            BagError: the message is not an announcement (its text says why).
        """
        document = decode_json(RawMessage(EPISODE, STRING, 0, data))
        if document.get('shutdown'):
            return Announced(None, None, [], shutdown=True)
        try:
            setup = EpisodeSetup.from_announcement(document)
        except AnnouncementError as error:
            raise BagError(str(error)) from None
        current = self.episode
        if current is not None and (setup.episode, setup.start_ns) == \
                (current.setup.episode, current.setup.start_ns):
            return Announced(None, None, [])  # the latched announcement again
        closed, rows = self.close() if current is not None else (None, [])
        rows += self._open(setup, document, data)
        return Announced(setup, closed, rows)

    def episode_folder(self, episode: int) -> Path:
        """The folder that receives episode ``episode``'s bag (a subclass may choose another)."""
        return self.output_dir / f'episode_{episode}'

    def _open(self, setup: EpisodeSetup, document: dict[str, Any], data: bytes) -> list[Row]:
        folder = self.episode_folder(setup.episode)
        folder.mkdir(parents=True, exist_ok=True)
        path, n = folder / 'bag', 1
        while path.exists():
            path, n = folder / f'bag_{n}', n + 1
        bag = EpisodeBagWriter(path, chunk_period=self.chunk_period)
        metrics = metric_names()
        self.episode = EpisodeRecord(setup, bag, MetricsReplica(setup), metrics,
                               last_pose_ns=setup.start_ns)
        # Samples wait until the world's status says every cleaning event up to them is here.
        self.episode.replica.confirmed_ns = setup.start_ns
        self._last_recorded.clear()
        for topic in (EPISODE, STATUS, POSES, CLEANING, CUE_MAP, ROBOT_STATES, SOURCES,
                      *map(metric_topic, metrics)):
            self._add_topic(topic)
        bag.describe(document)
        bag.write(EPISODE, setup.start_ns, data)
        bag.flush()  # the seed and parameters survive even an immediate SIGKILL
        if self._obstacles is not None:
            self._write_obstacles()
        rows = self._samples([self.episode.replica.initial()])
        early, self._early = self._early, collections.deque()
        for topic, message in early:  # what came before the announcement, in order
            rows += self.route(topic, message)
        if self._early_status is not None and self._early_status[0].episode == setup.episode:
            rows += self._apply_status(*self._early_status)[1]  # the status came first
        self._early_status = None
        return rows

    def close(self, *, judge: bool = True) -> tuple[Closed | None, list[Row]]:
        """Take the last sample, close the bag and judge it (nothing open: (None, [])).

        The verdict is :func:`~swarm_metrics.completeness.check_bag_file` on the closed bag
        as it is on disk, the judgement ``analyze`` and the launcher pass on it too.
        ``judge=False`` skips it (a node stopped before the episode ended: its bag cannot be
        complete, and reading it back could outlast the stop signal's patience).
        """
        episode = self.episode
        if episode is None:
            return None, []
        rows: list[Row] = []
        try:
            rows = self._samples(episode.replica.finish())
        finally:
            self.episode = None
            episode.bag.close()
            self._closed_end_ns = max(self._closed_end_ns, self.now_ns, episode.last_pose_ns)
        findings = tuple(check_bag_file(episode.bag.path)) if judge else None
        return Closed(episode.setup.episode, episode.setup.start_ns, episode.bag.path,
                      episode.bag.messages, findings), rows

    def done(self) -> bool:
        """The open episode ended and everything the world counted has arrived."""
        return self.episode is not None and self.episode.all_arrived()

    # --- messages -------------------------------------------------------------------

    def status(self, data: bytes) -> tuple[bool, list[Row]]:
        """A /world/status message. Returns (whether it ends the open episode, finished or
        failed; metric rows it completes).

        Raises:
            BagError: the message does not hold a JSON object.
        """
        try:
            status = WorldStatus.from_dict(decode_json(RawMessage(STATUS, STRING, 0, data)))
        except ContractError as error:
            raise BagError(str(error)) from None
        self.now_ns = max(self.now_ns, status.time_ns)
        episode = self.episode
        if episode is None or status.episode != episode.setup.episode:
            self._early_status = (status, data)  # perhaps of the episode announced next
            return False, []
        return self._apply_status(status, data)

    def _apply_status(self, status: WorldStatus, data: bytes) -> tuple[bool, list[Row]]:
        episode = self._current
        self.write(STATUS, self.now_ns, data)
        if status.cleaning_events is None:  # a world that does not count: trust the order
            episode.replica.confirmed_ns = NEVER
        elif episode.counted is None or status.time_ns >= episode.counted[0]:
            episode.counted = (status.time_ns, status.cleaning_events)
        rows = self._confirm_cleaning()
        if status.state is WorldState.RUNNING:
            episode.running = True
        elif status.ended and episode.final is None:
            episode.final = status
            return True, rows
        return False, rows

    def _confirm_cleaning(self) -> list[Row]:
        """Take the samples up to the world's latest count once every cleaning event it
        counted is here (the cleaning events and the poses travel on two topics, and after a
        stall their repairs can come in any order)."""
        episode = self._current
        if episode.counted is None:
            return []
        time_ns, count = episode.counted
        if time_ns <= episode.replica.confirmed_ns or \
                bisect.bisect_right(episode.cleaning_stamps, time_ns) < count:
            return []
        episode.replica.confirmed_ns = time_ns
        return self._samples(episode.replica.advance(time_ns))

    def route(self, topic: str, data: bytes) -> list[Row]:
        """A /world/poses, /world/cleaning, /world/cue_map, /world/robot_states or
        /world/sources message; returns metric rows.

        The world steps an episode only after the node has said it records it, so its
        messages cannot come first; should they anyway (a world that does not wait), they are
        kept, up to EARLY_LIMIT, and filed once the announcement arrives. Messages older than
        the last closed episode are stale and dropped.
        """
        if topic == ROBOT_STATES:
            self.robot_states(data)
            return []
        if topic == SOURCES:
            self.sources(data)
            return []
        stamp = stamp_ns(data)
        self.now_ns = max(self.now_ns, stamp)
        episode = self.episode
        if episode is not None and stamp <= episode.setup.end_ns:
            if topic == CUE_MAP:
                self.periodic(topic, data)
            elif topic == POSES and stamp == episode.setup.start_ns:
                self._want_states(stamp)  # t = 0: its sample is the announcement's
            elif stamp > episode.setup.start_ns:
                return self._poses(stamp, data) if topic == POSES else self._cleaning(stamp,
                                                                                      data)
        elif stamp > self._closed_end_ns:
            self._keep_early(topic, data)
        return []

    def _keep_early(self, topic: str, data: bytes) -> None:
        if len(self._early) >= EARLY_LIMIT:
            self._early.popleft()
            self.early_lost += 1
        self._early.append((topic, data))

    def _poses(self, stamp: int, data: bytes) -> list[Row]:
        episode = self._current
        episode.last_pose_ns = max(episode.last_pose_ns, stamp)
        poses = None
        if episode.replica.due(stamp):
            poses = poses_of(decode(RawMessage(POSES, POSE_ARRAY, stamp, data)))
            if len(poses) != episode.setup.population:
                raise BagError(f'{POSES} carries {len(poses)} robots, the episode '
                               f'{episode.setup.population}')
        rows, sampled = episode.replica.pose(stamp, poses)
        if sampled or self.record_all:
            self.write(POSES, stamp, data)
        if sampled:
            self._want_states(stamp)
            if episode.counted is not None:  # the status may have confirmed its cleaning
                rows += episode.replica.advance(stamp)  # first (a world that holds here)
        else:
            episode.pose_skipped()
        return self._samples(rows)

    # --- the robots' states: paired with the poses by count --------------------------

    def _want_states(self, stamp: int) -> None:
        """The open episode's next pose is a sample at ``stamp``: record its states there."""
        data = self._current.pose_sampled(stamp)
        if data is not None:
            self._write_states(stamp, data)

    def robot_states(self, data: bytes) -> None:
        """A /world/robot_states message: the states that go with the world's next poses."""
        episode = self.episode
        if episode is None:
            self._keep_early(ROBOT_STATES, data)  # before the announcement (a hasty world)
            return
        stamp = episode.states_arrived(data)
        if stamp is not None:
            self._write_states(stamp, data)

    def _write_states(self, stamp: int, data: bytes) -> None:
        self.write(ROBOT_STATES, stamp, data)
        if stamp == self._current.setup.start_ns:
            self._current.started.add(ROBOT_STATES)

    def sources(self, data: bytes) -> None:
        """A /world/sources message: recorded at its markers' stamp, as often as the cue map
        (``cue_map_period``, and the one that ends the episode)."""
        stamp = markers_stamp_ns(data)
        episode = self.episode
        if stamp is None:
            return
        if episode is None:
            if stamp > self._closed_end_ns:
                self._keep_early(SOURCES, data)  # before the announcement (a hasty world)
            return
        if episode.setup.start_ns <= stamp <= episode.setup.end_ns:  # else: the last one's
            self.periodic(SOURCES, data, stamp)

    def _cleaning(self, stamp: int, data: bytes) -> list[Row]:
        episode = self._current
        episode.replica.cleaning(stamp, poses_of(decode(RawMessage(CLEANING, POSE_ARRAY, stamp,
                                                                   data))))
        self.write(CLEANING, stamp, data)
        episode.cleaning += 1
        bisect.insort(episode.cleaning_stamps, stamp)
        return self._confirm_cleaning()

    def obstacles(self, data: bytes) -> None:
        """A /world/obstacles message: static scenery, published once (latched) by the world.

        It is kept, and every episode's bag records it once, at the episode's start: the one
        open now (unless it has it already) and each one opened later.
        """
        self._obstacles = bytes(data)
        if self.episode is not None and not self.episode.obstacles:
            self._write_obstacles()

    def _write_obstacles(self) -> None:
        self.write(OBSTACLES, self._current.setup.start_ns, cast(bytes, self._obstacles))
        self._current.obstacles = True

    def periodic(self, topic: str, data: bytes, stamp: int | None = None) -> None:
        """Record a /clock, /world/cue_map or /world/sources message (``stamp``: its time,
        default its header's): at most one per period, and the one that ends the episode
        (the final cue map)."""
        stamp = stamp_ns(data) if stamp is None else stamp
        self.now_ns = max(self.now_ns, stamp)
        if self.episode is None:
            return
        if topic == CUE_MAP:
            self.episode.last_map_ns = max(self.episode.last_map_ns, stamp)
        elif topic == SOURCES:
            self.episode.last_sources_ns = max(self.episode.last_sources_ns, stamp)
        last = self._last_recorded.get(topic)
        if last == stamp and not self.record_all:
            # The same instant again: the world's end publishes the last step's map a second
            # time, and whether the first one reaches us (keep-last-1) is a race.
            return
        if (self.record_all or last is None or stamp - last >= self.periods_ns[topic]
                or stamp >= self.episode.setup.end_ns):
            self._last_recorded[topic] = stamp
            self.write(topic, stamp, data)
            if stamp == self.episode.setup.start_ns:
                self.episode.started.add(topic)

    def stamped(self, topic: str, data: bytes) -> None:
        """Record a message with a header (record_all's per-robot topics) at its stamp."""
        stamp = stamp_ns(data)
        self.now_ns = max(self.now_ns, stamp)
        self.write(topic, stamp, data)

    def _samples(self, rows: list[Row]) -> list[Row]:
        """Record metric rows in the bag; return them."""
        for log_ns, row in rows:
            for name in self._current.metrics:
                self.write(metric_topic(name), log_ns, float64_cdr(float(row[name])))
            self._current.samples += 1
        return rows

    def write(self, topic: str, log_ns: int, data: bytes) -> None:
        """Record a message in the open bag (none open: nothing)."""
        if self.episode is None:
            return
        self._add_topic(topic)
        self.episode.bag.write(topic, log_ns, data)

    def _add_topic(self, topic: str) -> None:
        bag = self._current.bag
        if not bag.has_topic(topic):
            entry = topic_of(topic)
            if entry is None:
                raise BagError(f'{topic} is not a topic of the contract (docs/interfaces.md)')
            bag.add_topic(topic, entry.type, [offered(entry.qos)])
