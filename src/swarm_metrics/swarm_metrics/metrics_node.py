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
"""

from __future__ import annotations

import struct
import sys
import time
from pathlib import Path

import rclpy
from geometry_msgs.msg import PoseArray, TwistStamped
from nav_msgs.msg import OccupancyGrid
from rclpy.clock import Clock, ClockType
from rclpy.exceptions import ParameterException
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
from swarm_metrics.analysis import METRIC_NAMES, AnnouncementError, EpisodeSetup, MetricsReplica
from swarm_metrics.bag_reader import BagError, RawMessage, decode, decode_json, poses_of
from swarm_metrics.bag_writer import CHUNK_PERIOD, EpisodeBagWriter, offered_qos

EXIT_WORLD_LOST = 3
METRICS_QOS = QoSProfile(depth=10)


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

    def __init__(self) -> None:
        super().__init__('metrics')
        self.output_dir = Path(self._declare('output_dir', 'results/ros',
                                             'folder that receives episode_<k>/bag'))
        self.record_all = self._declare('record_all', False,
                                        'also record every per-robot topic and every world '
                                        'topic at full rate')
        self.chunk_period = self._declare('chunk_period', CHUNK_PERIOD,
                                          'sim seconds per bag chunk: the most a SIGKILL loses',
                                          0.1, 3600.0)
        self.cue_map_period = self._declare('cue_map_period', 10.0,
                                            'record /world/cue_map at most this often (sim s; '
                                            '0: every map)', 0.0, 1e6)
        self.clock_period = self._declare('clock_period', 0.1,
                                          'record /clock at most this often (sim s; 0: every '
                                          'tick)', 0.0, 1e6)
        self.world_lost_after = self._declare('world_lost_after', 10.0,
                                           'wall seconds without /world/status or poses while '
                                           'running before the world counts as lost', 0.5, 1e6)
        self.finish_grace = self._declare('finish_grace', 1.0,
                                          'wall seconds to keep recording after the world '
                                          'reports finished', 0.0, 60.0)
        self.done = Future()  #: set to the exit status when the node should stop
        self.bag: EpisodeBagWriter | None = None
        self.setup: EpisodeSetup | None = None
        self.replica: MetricsReplica | None = None
        self.running = False
        self.now_ns = 0  # the latest sim time seen, for messages without a stamp
        self._last_recorded: dict[str, int] = {}
        self._last_world = time.monotonic()
        self._closing_at: float | None = None
        self._robot_subscriptions: set[int] = set()
        # topic -> (type, offered QoS) of everything this node may record
        self._topics = {f'/metrics/{name}': (type_name(Float64), bag_qos(METRICS_QOS))
                        for name in METRIC_NAMES}
        self._metric_publishers = {name: self.create_publisher(Float64, f'/metrics/{name}',
                                                        METRICS_QOS)
                            for name in METRIC_NAMES}
        self._subscribe(String, qos.EPISODE, qos.EPISODE_QOS, self._on_episode)
        self._subscribe(String, qos.STATUS, qos.STATUS_QOS, self._on_status)
        self._subscribe(PoseArray, qos.POSES, qos.POSES_QOS, self._on_poses)
        self._subscribe(PoseArray, qos.CLEANING, qos.CLEANING_QOS, self._on_cleaning)
        self._subscribe(Image, qos.CUE_MAP, qos.MAP_QOS, self._on_periodic(
            qos.CUE_MAP, self.cue_map_period))
        self._subscribe(ClockMsg, qos.CLOCK, qos.CLOCK_QOS, self._on_periodic(
            qos.CLOCK, self.clock_period))
        if self.record_all:
            self._subscribe(OccupancyGrid, qos.CUE_GRID, qos.MAP_QOS, self._on_stamped)
            self._subscribe(MarkerArray, qos.MARKERS, qos.MARKERS_QOS, self._on_unstamped)
        # Wall time, so a stalled /clock cannot stall the watchdog.
        self._shutdown_requested = False
        self.create_timer(0.5, self._tick, clock=Clock(clock_type=ClockType.STEADY_TIME))
        self.get_logger().info(f'recording episodes into {self.output_dir} '
                               f'(record_all={self.record_all})')

    # --- set-up -----------------------------------------------------------------------

    def _declare(self, name: str, default, doc: str, low: float | None = None,
                 high: float | None = None):
        """Declare a parameter; a value out of [low, high] raises ValueError naming it."""
        value = self.declare_parameter(name, default).value
        if low is not None and not low <= value <= high:
            raise ValueError(f'parameter {name} = {value} is out of range: allowed '
                             f'[{low:g}, {high:g}] ({doc})')
        return value

    def _subscribe(self, msg_class: type, topic: str, profile: QoSProfile, callback) -> None:
        """A raw subscription that also remembers how to record the topic."""
        self._topics[topic] = (type_name(msg_class), bag_qos(profile))
        self.create_subscription(msg_class, topic,
                                 lambda data, t=topic: callback(t, data), profile, raw=True)

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
        self.bag = EpisodeBagWriter(path, chunk_period=self.chunk_period)
        self.setup, self.replica = setup, MetricsReplica(setup)
        self.running, self._closing_at = False, None
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

    def close(self, reason: str, *, publish: bool = True) -> None:
        """Take the last sample and close the bag (safe to call when none is open)."""
        bag = self.bag
        if bag is None:
            return
        try:
            if self.replica is not None:
                self._emit(self.replica.finish(), publish=publish)
                if self.replica.late_events:
                    self.get_logger().warning(f'{self.replica.late_events} cleaning events '
                                              f'arrived after their time was sampled')
        finally:
            self.bag = None
            bag.close()
            self.running, self.replica, self._closing_at = False, None, None
            self.get_logger().info(f'closed {bag.path} ({bag.messages} messages): {reason}')

    def _emit(self, rows, *, publish: bool = True) -> None:
        """Publish and record metrics rows [(log ns, row)]."""
        for log_ns, row in rows:
            for name in METRIC_NAMES:
                msg = Float64(data=float(row[name]))
                if publish:
                    self._metric_publishers[name].publish(msg)
                self._record(f'/metrics/{name}', log_ns, serialize_message(msg))

    # --- callbacks --------------------------------------------------------------------

    def _on_episode(self, topic: str, data: bytes) -> None:
        try:
            announcement = decode_json(RawMessage(topic, type_name(String), 0, data))
            if announcement.get('shutdown'):
                # The world's last status and poses travel on other topics and may still be
                # on their way: close after the same grace as a finished episode.
                self._shutdown_requested = True
                if self.bag is None:
                    self.done.set_result(0) if not self.done.done() else None
                elif self._closing_at is None:
                    self._closing_at = time.monotonic() + self.finish_grace
                return
            setup = EpisodeSetup.from_announcement(announcement)
        except (BagError, AnnouncementError) as error:
            self.get_logger().error(f'ignoring a bad /episode announcement: {error}')
            return
        if self.setup is not None and self.bag is not None \
                and setup.episode == self.setup.episode:
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
        if status.get('state') == 'running':
            self.running = True
        elif status.get('state') in ('finished', 'failed') and self._closing_at is None:
            self._closing_at = time.monotonic() + self.finish_grace

    def _on_poses(self, topic: str, data: bytes) -> None:
        self._last_world = time.monotonic()
        stamp = stamp_ns(data)
        self.now_ns = max(self.now_ns, stamp)
        if self.replica is None or stamp <= self.setup.start_ns:
            return
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

    def _on_cleaning(self, topic: str, data: bytes) -> None:
        stamp = stamp_ns(data)
        if self.replica is None or stamp <= self.setup.start_ns:
            return
        self.replica.cleaning(stamp, poses_of(decode(RawMessage(topic, type_name(PoseArray),
                                                                stamp, data))))
        self._record(topic, stamp, data)

    def _on_periodic(self, topic: str, period: float):
        """A callback recording ``topic`` at most once per ``period`` of sim time, and at the
        episode's end (the final cue map)."""
        period_ns = round(period * 1e9)

        def callback(topic: str, data: bytes) -> None:
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

    def _tick(self) -> None:
        """Close a finished episode after its grace; give up on a silent world."""
        now = time.monotonic()
        if self._closing_at is not None and now >= self._closing_at:
            self.close('the supervisor announced the shutdown' if self._shutdown_requested
                       else 'the world finished the episode')
            if self._shutdown_requested and not self.done.done():
                self.done.set_result(0)
        elif self.running and now - self._last_world > self.world_lost_after:
            self.get_logger().error(f'no /world/status or /world/poses for '
                                    f'{self.world_lost_after:g} s while running: the world is '
                                    f'lost')
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
    except (ValueError, ParameterException) as error:  # a bad parameter
        print(f'metrics_node: error: {error}', file=sys.stderr)
        status = 2
    finally:
        if node is not None:
            node.close('the node is stopping', publish=False)
            node.destroy_node()
        rclpy.try_shutdown()
    return status


if __name__ == '__main__':
    sys.exit(main())
