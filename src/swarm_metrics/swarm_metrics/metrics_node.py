"""The metrics node: online metrics on /metrics/<name> and one bag per episode.

It keeps a replica of the cue by applying each /world/cleaning event with the world's own
cleaning function (:class:`swarm_metrics.analysis.MetricsReplica`), samples the metrics once
per ``sample_period`` of sim time, publishes them and records them, so the online numbers and
``mona-swarm analyze`` on the bag agree by construction.

Each announced episode k gets the bag ``<output_dir>/episode_<k>/bag`` (rosbag2 layout, MCAP,
zstd). Messages are recorded as the CDR bytes that arrived (raw subscriptions), log time = the
sim time they describe. Exit status: 0 after the supervisor's shutdown announcement or
SIGINT/SIGTERM, 3 when the world stops talking while an episode runs, 2 for bad parameters;
the bag is closed on every path.

The node is a *recorder* (docs/interfaces.md, "Recorders"): on /recorders it says when an
episode's bag is open and listening (the world starts step 0 only then), how far its record is
whole (the world never runs more than ``recorder_lag`` ahead), and, when it closes the bag,
whether the record is complete. It closes a finished episode as soon as everything the
world's final status counts has arrived, or after ``finish_timeout`` as incomplete.
"""

from __future__ import annotations

import dataclasses
import struct
import sys
import time
from collections import deque
from pathlib import Path

import rclpy
from geometry_msgs.msg import PoseArray, TwistStamped
from nav_msgs.msg import OccupancyGrid
from rclpy.clock import Clock, ClockType
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import serialize_message
from rclpy.task import Future
from rosgraph_msgs.msg import Clock as ClockMsg
from sensor_msgs.msg import Image, LaserScan
from std_msgs.msg import Bool, Float64, String
from visualization_msgs.msg import MarkerArray

from mona_controller import qos
from mona_controller.contract import RecorderReport, RecorderState, WorldState
from mona_controller.ros_params import declare_section
from mona_controller.schema import ParameterError, param, validate
from mona_controller.shutdown import teardown
from swarm_metrics.analysis import METRIC_NAMES, AnnouncementError, EpisodeSetup, MetricsReplica
from swarm_metrics.bag_reader import BagError, RawMessage, decode, decode_json, poses_of
from swarm_metrics.bag_writer import CHUNK_PERIOD, EpisodeBagWriter, offered_qos

EXIT_WORLD_LOST = 3
METRICS_QOS = QoSProfile(depth=10)
#: Wall seconds between looks at the world's health and the episode's end.
TICK = 0.1
#: Messages of an episode not yet announced that are kept for its bag (see _route).
EARLY_LIMIT = 20_000


@dataclasses.dataclass(frozen=True)
class MetricsNodeParams:
    """Options of the metrics node (what and how it records; not part of the model)."""

    output_dir: str = param('results/ros', doc='folder that receives episode_<k>/bag')
    record_all: bool = param(False, doc='also record every per-robot topic and every world '
                                        'topic at full rate')
    chunk_period: float = param(CHUNK_PERIOD, unit='s (sim)', low=0.1, high=3600.0,
                                doc='sim seconds per bag chunk: the most a SIGKILL loses')
    cue_map_period: float = param(10.0, unit='s (sim)', low=0.0, high=1e6,
                                  doc='record /world/cue_map at most this often (0: every map)')
    clock_period: float = param(0.1, unit='s (sim)', low=0.0, high=1e6,
                                doc='record /clock at most this often (0: every tick)')
    world_lost_after: float = param(10.0, unit='s (wall)', low=0.5, high=1e6,
                                    doc='no /world/status or poses this long while running: '
                                        'the world is lost (close the bag, exit 3)')
    finish_timeout: float = param(10.0, unit='s (wall)', low=0.0, high=3600.0,
                                  doc='after the world reports the end, how long to wait for '
                                      'the messages it counts before the bag closes incomplete')

    def __post_init__(self) -> None:
        validate(self)


def type_name(msg_class: type) -> str:
    """'pkg/msg/Name' of an rclpy message class (the name rosbags and rosbag2 use)."""
    return f'{msg_class.__module__.split(".")[0]}/msg/{msg_class.__name__}'


def stamp_ns(data: bytes) -> int:
    """The stamp of a serialized message whose first field is a Time (a Header, a Clock).

    Reads the CDR bytes directly (encapsulation, then sec int32 and nanosec uint32), so a
    recorded message needs no deserialization.
    """
    sec, nanosec = struct.unpack_from('<iI' if data[1] == 1 else '>iI', data, 4)
    return sec * 1_000_000_000 + nanosec


def bag_qos(profile: QoSProfile):
    """The rosbags form of an rclpy QoS profile (recorded as the topic's offered QoS)."""
    return offered_qos(profile.depth,
                       reliable=profile.reliability == ReliabilityPolicy.RELIABLE,
                       latched=profile.durability == DurabilityPolicy.TRANSIENT_LOCAL)


class MetricsNode(Node):
    """Computes the metrics online and records each episode's bag."""

    def __init__(self, **kwargs) -> None:
        super().__init__('metrics', **kwargs)
        options = declare_section(self, MetricsNodeParams)
        self.options = options
        self.output_dir = Path(options.output_dir)
        self.record_all = options.record_all
        self.done = Future()  #: set to the exit status when the node should stop
        self.bag: EpisodeBagWriter | None = None
        self.setup: EpisodeSetup | None = None
        self.replica: MetricsReplica | None = None
        self.running = False
        self.now_ns = 0  # the latest sim time seen, for messages without a stamp
        self._last_recorded: dict[str, int] = {}
        self._last_world = self._last_tick = time.monotonic()
        self._closing_at: float | None = None  # wall time at which to give up on the rest
        self._final: dict | None = None  # the world's finished/failed status of the episode
        self._confirmed = False  # the episode's "recording" report is out
        self._samples = 0  # metric samples taken this episode (t = 0 included)
        self._cleaning = 0  # /world/cleaning messages recorded this episode
        self._last_pose_ns = 0
        self._closed_end_ns = -1  # end of the last closed episode: older messages are stale
        self._early: deque[tuple[str, int, bytes]] = deque()
        self._early_lost = 0
        self._bag_path = Path()
        self._robot_subscriptions: set[int] = set()
        # topic -> (type, offered QoS) of everything this node may record
        self._topics = {f'/metrics/{name}': (type_name(Float64), bag_qos(METRICS_QOS))
                        for name in METRIC_NAMES}
        self._metric_publishers = {name: self.create_publisher(Float64, f'/metrics/{name}',
                                                               METRICS_QOS)
                                   for name in METRIC_NAMES}
        self.report_pub = self.create_publisher(String, qos.RECORDERS, qos.RECORDERS_QOS)
        self._subscribe(String, qos.EPISODE, qos.EPISODE_QOS, self._on_episode)
        self._subscribe(String, qos.STATUS, qos.STATUS_QOS, self._on_status)
        # Messages that belong to an episode go through _route (see there).
        self._handlers = {qos.POSES: self._on_poses, qos.CLEANING: self._on_cleaning,
                          qos.CUE_MAP: self._on_periodic(options.cue_map_period)}
        self.world_subscriptions = [
            self._subscribe(PoseArray, qos.POSES, qos.POSES_QOS, self._route),
            self._subscribe(PoseArray, qos.CLEANING, qos.CLEANING_QOS, self._route)]
        self._subscribe(Image, qos.CUE_MAP, qos.MAP_QOS, self._route)
        self._subscribe(ClockMsg, qos.CLOCK, qos.CLOCK_QOS,
                        self._on_periodic(options.clock_period))
        if self.record_all:
            self._subscribe(OccupancyGrid, qos.CUE_GRID, qos.MAP_QOS, self._on_stamped)
            self._subscribe(MarkerArray, qos.MARKERS, qos.MARKERS_QOS, self._on_unstamped)
        # Wall time, so a stalled /clock cannot stall the watchdog.
        self._shutdown_requested = False
        self.create_timer(TICK, self._tick, clock=Clock(clock_type=ClockType.STEADY_TIME))
        self.get_logger().info(f'recording episodes into {self.output_dir} '
                               f'(record_all={self.record_all})')

    # --- set-up -----------------------------------------------------------------------

    def _subscribe(self, msg_class: type, topic: str, profile: QoSProfile, callback):
        """A raw subscription that also remembers how to record the topic."""
        self._topics[topic] = (type_name(msg_class), bag_qos(profile))
        return self.create_subscription(msg_class, topic,
                                        lambda data, t=topic: callback(t, data), profile,
                                        raw=True)

    def _subscribe_robots(self, population: int) -> None:
        """record_all: every robot's sensor and command topics."""
        for i in range(population):
            if i in self._robot_subscriptions:
                continue
            self._robot_subscriptions.add(i)
            for msg_class, name, profile, callback in (
                    (Image, qos.GROUND, qos.SENSOR_QOS, self._on_stamped),
                    (LaserScan, qos.PROXIMITY, qos.SENSOR_QOS, self._on_stamped),
                    (TwistStamped, qos.CMD_VEL, qos.COMMAND_QOS, self._on_stamped),
                    (Bool, qos.CLEANER, qos.CLEANER_QOS, self._on_unstamped)):
                self._subscribe(msg_class, qos.robot_topic(i, name), profile, callback)

    # --- recording --------------------------------------------------------------------

    def _record(self, topic: str, log_ns: int, data: bytes) -> None:
        if self.bag is None:
            return
        if not self.bag.has_topic(topic):
            msgtype, profile = self._topics[topic]
            self.bag.add_topic(topic, msgtype, [profile])
        self.bag.write(topic, log_ns, data)

    def _open(self, setup: EpisodeSetup, announcement: dict, data: bytes) -> None:
        """Start episode ``setup.episode``: a new bag holding the announcement first."""
        folder = self.output_dir / f'episode_{setup.episode}'
        folder.mkdir(parents=True, exist_ok=True)
        path, n = folder / 'bag', 1
        while path.exists():  # a rerun into the same folder never overwrites a bag
            path, n = folder / f'bag_{n}', n + 1
        self.bag = EpisodeBagWriter(path, chunk_period=self.options.chunk_period)
        self._bag_path = path
        self.setup, self.replica = setup, MetricsReplica(setup)
        self.running, self._closing_at, self._final = False, None, None
        self._confirmed, self._samples, self._cleaning = False, 0, 0
        self._last_pose_ns = setup.start_ns
        self._last_recorded.clear()
        for topic in (qos.EPISODE, qos.STATUS, qos.POSES, qos.CLEANING, qos.CUE_MAP,
                      *(f'/metrics/{name}' for name in METRIC_NAMES)):
            msgtype, profile = self._topics[topic]
            self.bag.add_topic(topic, msgtype, [profile])
        self.bag.describe(announcement)
        self._record(qos.EPISODE, setup.start_ns, data)
        self.bag.flush()  # the seed and parameters survive even an immediate SIGKILL
        self._emit([self.replica.initial()])
        if self.record_all:
            self._subscribe_robots(setup.population)
        self.get_logger().info(f'episode {setup.episode} (seed {setup.seed}, N = '
                               f'{setup.population}): recording {path}')
        early, self._early = self._early, deque()
        for topic, stamp, message in early:  # what came before the announcement, in order
            self._route(topic, message)
        self._confirm()

    def _confirm(self) -> None:
        """Say "recording" once the bag is open and the world's poses and cleaning events can
        reach it (matched subscriptions: their topics keep no history for late joiners)."""
        if self._confirmed or self.bag is None:
            return
        if all(s.get_publisher_count() > 0 for s in self.world_subscriptions):
            self._confirmed = True
            self._report(RecorderState.RECORDING)

    def _report(self, state: RecorderState, complete: bool = False,
                problems: tuple[str, ...] = ()) -> None:
        """Publish this recorder's word on the current episode (/recorders)."""
        if self.setup is None:
            return
        recorded = self.setup.start_ns + max(self._samples - 1, 0) * self.setup.sample_ns
        report = RecorderReport(self.get_name(), self.setup.episode, self.setup.start_ns,
                                state, recorded, complete, problems, str(self._bag_path))
        self.report_pub.publish(String(data=report.to_json()))

    def _problems(self) -> list[str]:
        """What this episode's record lacks (nothing: it is complete)."""
        problems = []
        final = self._final or {}
        if final.get('state') != WorldState.FINISHED.value:
            problems.append('the world did not report the episode finished'
                            + (f' (it {final.get("state")}: {final.get("error")})'
                               if final else ''))
        end_ns = final.get('time_ns', self.setup.end_ns)
        expected = (end_ns - self.setup.start_ns) // self.setup.sample_ns + 1
        if self._samples != expected:
            problems.append(f'{self._samples} of {expected} metric samples (t = 0 .. '
                            f'{(expected - 1) * self.setup.metrics.sample_period:g} s)')
        counted = final.get('cleaning_events')
        if isinstance(counted, int) and self._cleaning != counted:
            problems.append(f'{self._cleaning} of the {counted} cleaning events')
        if self.replica is not None and self.replica.late_events:
            problems.append(f'{self.replica.late_events} cleaning events arrived after their '
                            'time was sampled')
        return problems

    def _all_arrived(self) -> bool:
        """The world reported the end and everything its final status counts is here."""
        final = self._final
        if final is None:
            return False
        counted = final.get('cleaning_events')
        return (self._last_pose_ns >= final.get('time_ns', self.setup.end_ns)
                and (not isinstance(counted, int) or self._cleaning >= counted))

    def close(self, reason: str, *, publish: bool = True) -> None:
        """Take the last sample, close the bag and report (safe to call when none is open)."""
        bag = self.bag
        if bag is None:
            return
        problems: list[str] = []
        try:
            if self.replica is not None:
                self._emit(self.replica.finish(), publish=publish)
                problems = self._problems()
        finally:
            self.bag = None
            bag.close()
            self.running, self.replica, self._closing_at = False, None, None
            self._closed_end_ns = max(self._closed_end_ns, self.now_ns, self._last_pose_ns)
        if problems:
            self.get_logger().error(f'closed {bag.path} ({bag.messages} messages), '
                                    f'INCOMPLETE: {"; ".join(problems)} ({reason})')
        else:
            self.get_logger().info(f'closed {bag.path} ({bag.messages} messages), complete: '
                                   f'{reason}')
        if publish:
            self._report(RecorderState.CLOSED, not problems, tuple(problems))

    def _emit(self, rows, *, publish: bool = True) -> None:
        """Publish and record metrics rows [(log ns, row)]."""
        for log_ns, row in rows:
            for name in METRIC_NAMES:
                msg = Float64(data=float(row[name]))
                if publish:
                    self._metric_publishers[name].publish(msg)
                self._record(f'/metrics/{name}', log_ns, serialize_message(msg))
            self._samples += 1
        if rows and self._confirmed:
            self._report(RecorderState.RECORDING)  # progress: the world may run further

    # --- callbacks --------------------------------------------------------------------

    def _on_episode(self, topic: str, data: bytes) -> None:
        try:
            announcement = decode_json(RawMessage(topic, type_name(String), 0, data))
            if announcement.get('shutdown'):
                # The world's last messages travel on other topics and may still be on their
                # way: a finished episode closes once they are in (or after finish_timeout).
                self._shutdown_requested = True
                if self.bag is None:
                    self.done.set_result(0) if not self.done.done() else None
                elif self._closing_at is None:
                    self._closing_at = time.monotonic() + self.options.finish_timeout
                return
            setup = EpisodeSetup.from_announcement(announcement)
        except (BagError, AnnouncementError) as error:
            self.get_logger().error(f'ignoring a bad /episode announcement: {error}')
            return
        if self.setup is not None and (setup.episode, setup.start_ns) == \
                (self.setup.episode, self.setup.start_ns):
            return  # the latched announcement again
        self.close(f'episode {setup.episode} was announced')
        self._open(setup, announcement, data)

    def _on_status(self, topic: str, data: bytes) -> None:
        self._last_world = time.monotonic()
        try:
            status = decode_json(RawMessage(topic, type_name(String), 0, data))
        except BagError as error:
            self.get_logger().warning(str(error))
            return
        time_ns = status.get('time_ns')
        if isinstance(time_ns, int) and time_ns >= 0:
            self.now_ns = max(self.now_ns, time_ns)
        if self.bag is None or self.setup is None or status.get('episode') != self.setup.episode:
            return
        self._record(topic, self.now_ns, data)
        state = status.get('state')
        if state == WorldState.RUNNING.value:
            self.running = True
        elif state in (WorldState.FINISHED.value, WorldState.FAILED.value) \
                and self._final is None:
            self._final = status
            self._closing_at = time.monotonic() + self.options.finish_timeout
            self._close_if_done()

    def _route(self, topic: str, data: bytes) -> None:
        """Hand an episode's message to its handler, or keep it for an episode not yet open.

        The world steps an episode only after this node has said it records it, so its
        messages cannot come first; should they anyway (a world that does not wait), they are
        kept, up to EARLY_LIMIT, and filed once the announcement arrives. Messages older than
        the last closed episode are stale and dropped.
        """
        stamp = stamp_ns(data)
        if self.setup is not None and self.bag is not None \
                and stamp <= self.setup.end_ns:
            if stamp > self.setup.start_ns or topic == qos.CUE_MAP:
                self._handlers[topic](topic, stamp, data)
        elif stamp > self._closed_end_ns:
            if len(self._early) >= EARLY_LIMIT:
                self._early.popleft()
                self._early_lost += 1
                self.get_logger().error(f'{self._early_lost} messages of an episode not yet '
                                        'announced were lost', throttle_duration_sec=5.0)
            self._early.append((topic, stamp, data))

    def _on_poses(self, topic: str, stamp: int, data: bytes) -> None:
        self._last_world = time.monotonic()
        self.now_ns = max(self.now_ns, stamp)
        self._last_pose_ns = max(self._last_pose_ns, stamp)
        poses = None
        if self.replica.due(stamp):
            poses = poses_of(decode(RawMessage(topic, type_name(PoseArray), stamp, data)))
            if len(poses) != self.setup.population:
                self.get_logger().error(f'{topic} carries {len(poses)} robots, the episode '
                                        f'{self.setup.population}; ignored')
                return
        rows, sampled = self.replica.pose(stamp, poses)
        self._emit(rows)
        if sampled or self.record_all:
            self._record(topic, stamp, data)
        self._close_if_done()

    def _on_cleaning(self, topic: str, stamp: int, data: bytes) -> None:
        self.replica.cleaning(stamp, poses_of(decode(RawMessage(topic, type_name(PoseArray),
                                                                stamp, data))))
        self._record(topic, stamp, data)
        self._cleaning += 1
        self._close_if_done()

    def _on_periodic(self, period: float):
        """A callback recording its topic at most once per ``period`` of sim time, and at the
        episode's end (the final cue map)."""
        period_ns = round(period * 1e9)

        def callback(topic: str, *message) -> None:
            data = message[-1]  # (data) from a subscription, (stamp, data) from _route
            stamp = stamp_ns(data)
            self.now_ns = max(self.now_ns, stamp)
            last = self._last_recorded.get(topic)
            final = self.setup is not None and stamp >= self.setup.end_ns
            if self.record_all or last is None or stamp - last >= period_ns or final:
                self._last_recorded[topic] = stamp
                self._record(topic, stamp, data)
        return callback

    def _on_stamped(self, topic: str, data: bytes) -> None:
        stamp = stamp_ns(data)
        self.now_ns = max(self.now_ns, stamp)
        self._record(topic, stamp, data)

    def _on_unstamped(self, topic: str, data: bytes) -> None:
        self._record(topic, self.now_ns, data)

    def _close_if_done(self) -> None:
        if self.bag is not None and self._all_arrived():
            self._close_episode()

    def _close_episode(self) -> None:
        """Close the ended episode's bag; after the shutdown announcement, stop."""
        self.close('the supervisor announced the shutdown' if self._shutdown_requested
                   else f'the world {(self._final or {}).get("state", "ended")} the episode')
        if self._shutdown_requested and not self.done.done():
            self.done.set_result(0)

    def _tick(self) -> None:
        """Confirm recording, close an ended episode whose rest never came, and give up on a
        silent world."""
        now = time.monotonic()
        if now - self._last_tick > 10 * TICK:
            # This node itself was stalled (swapped out, SIGSTOPped): the world's messages
            # wait in the queues, so its silence is not the world's.
            self._last_world = now
        self._last_tick = now
        self._confirm()
        if self._closing_at is not None and now >= self._closing_at:
            self._close_episode()
        elif self.running and now - self._last_world > self.options.world_lost_after:
            self.get_logger().error(f'no /world/status or /world/poses for '
                                    f'{self.options.world_lost_after:g} s while running: the '
                                    f'world is lost')
            self.close('the world was lost')
            if not self.done.done():
                self.done.set_result(EXIT_WORLD_LOST)


def main(args: list[str] | None = None) -> int:
    """Run the metrics node until the shutdown announcement, a signal or a lost world."""
    rclpy.init(args=args)
    node = None
    status = 0
    try:
        node = MetricsNode()
        rclpy.spin_until_future_complete(node, node.done)
        status = node.done.result() if node.done.done() else 0
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except ParameterError as error:
        rclpy.logging.get_logger('metrics').fatal(f'bad parameter: {error}')
        status = 2
    finally:
        if node is not None:
            node.close('the node is stopping', publish=False)  # durable before teardown
        teardown([node])
    return status


if __name__ == '__main__':
    sys.exit(main())
