"""The live node: the node system's episode served to Foxglove (``scripts/swarm.sh --live``).

A thin adapter: it subscribes to the world's, the supervisor's and the metrics node's topics
as raw CDR (the bytes the metrics node records) and forwards them to a
:class:`~swarm_supervisor.media.live.LiveServer`, so Foxglove decodes them with their own ROS 2
definitions and the live view equals the bag. The frequent topics are thinned to what a
person can watch (poses, markers and clock at most ``rate`` per wall second, the cue map and
grid ``map_rate``); the announcement, the latest status and the obstacles are repeated once a
second for a client that connects late. After the supervisor's shutdown announcement it
keeps serving the run's final state (the latest message of every topic, sent again once a
second) for ``linger`` wall seconds (-1: until SIGINT/SIGTERM; 0: it stops at once). It logs
``live view following the world`` once the world's per-step topics reach it: the launcher
starts the supervisor (so the first episode) only then, so the live view misses no step and
holds the run's final state however late it started on a busy machine. Once it holds an
episode's final state (its announcement, the world's finished status and the poses of its last
step) it says so on ``/recorders`` as recorder ``live``: the launcher lists it among the
supervisor's recorders, so the run goes on (to the next episode, or the shutdown) only once
the live view holds what it is to show, however long a busy machine kept it. Exit status: 0 after
the shutdown announcement and its linger, or SIGINT/SIGTERM; 2 for a bad parameter or a port
it cannot listen on.

    python -m swarm_supervisor.system.ros.live_node --ros-args -p port:=8765
"""

from __future__ import annotations

import dataclasses
import json
import struct
import sys
import time

import rclpy
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.task import Future
from std_msgs.msg import String

from mona_controller.contract import (
    ContractError,
    RecorderReport,
    RecorderState,
    WorldState,
    WorldStatus,
)
from mona_controller.node_help import node_parser, parse_node_args
from mona_controller.ros import qos
from mona_controller.ros.ros_params import declare_plugins, declare_section
from mona_controller.ros.shutdown import STOPPED, raise_unless_stopped, teardown
from mona_controller.schema import ParameterError, param, validate
from swarm_supervisor.media.live import DEFAULT_PORT, MAP_RATE, RATE, LiveServer, live_topics
from swarm_supervisor.system.processes import LIVE_READY
from swarm_supervisor.system.records import LIVE_RECORDER
from swarm_world.messages.cdr import stamp_ns

#: The world's topics published with every step and kept for no late subscriber: the live
#: view must be subscribed before step 0 to show the episode and, after it, its final state.
STEPPED = (qos.POSES, qos.ROBOT_STATES, qos.MARKERS)


def message_stamp(topic: str, data: bytes) -> int:
    """The sim time (ns) a forwarded message describes: its header's stamp; a marker array
    has no header, so its first marker's (the robot markers all share one stamp, and so do
    the sources')."""
    if topic in (qos.MARKERS, qos.SOURCES, qos.OBSTACLES):
        if len(data) < 16:
            return 0  # no markers
        sec, nanosec = struct.unpack_from('<iI' if data[1] == 1 else '>iI', data, 8)
        return sec * 1_000_000_000 + nanosec
    return stamp_ns(data)


def node_topics() -> dict[str, str]:
    """What the node system's live view carries, with the types: what the embedded one
    does."""
    return dict(live_topics())


def __getattr__(name: str) -> object:
    # NODE_TOPICS reads as a constant but follows the metrics table.
    if name == 'NODE_TOPICS':
        return node_topics()
    raise AttributeError(f'module {__name__!r} has no attribute {name!r}')


@dataclasses.dataclass(frozen=True)
class LiveNodeParams:
    """Options of the live node."""

    port: int = param(DEFAULT_PORT, low=0, high=65535,
                      doc='WebSocket port of the live view (0: any free one, logged)')
    host: str = param('127.0.0.1', doc='interface to listen on (localhost: nothing leaves '
                                       'the machine)')
    rate: float = param(RATE, unit='1/s (wall)', low=0.1, high=1000.0,
                        doc='poses, markers and clock forwarded per wall second, at most')
    map_rate: float = param(MAP_RATE, unit='1/s (wall)', low=0.1, high=1000.0,
                            doc='cue maps and grids forwarded per wall second, at most')
    linger: float = param(0.0, unit='s (wall)', low=-1.0, high=1e6,
                          doc='after the shutdown announcement, keep serving the final state '
                              'this long (-1: until stopped by SIGINT/SIGTERM; 0: stop at once)')

    def __post_init__(self) -> None:
        validate(self)


class LiveNode(Node):
    """Forwards the recorded topics to Foxglove clients."""

    def __init__(self, **kwargs) -> None:
        super().__init__('live', **kwargs)
        declare_plugins(self)  # their metrics' channels
        self.options = declare_section(self, LiveNodeParams)
        self.done = Future()  #: set to the exit status when the node should stop
        forwarded = node_topics()
        self.topic_subscriptions: dict = {}
        self.server = LiveServer(self.options.port, self.options.host, forwarded)
        period, map_period = 1.0 / self.options.rate, 1.0 / self.options.map_rate
        self.min_interval = {qos.POSES: period, qos.MARKERS: period, qos.CLOCK: period,
                             qos.ROBOT_STATES: period, qos.CUE_MAP: map_period,
                             qos.CUE_GRID: map_period}
        self.last_sent: dict[str, float] = {}
        self.sim_ns = 0  # the latest sim time seen: the log time of unstamped messages
        #: The latest message of every topic, (log time, CDR): the final state, while lingering.
        self.latest: dict[str, tuple[int, bytes]] = {}
        self.lingering = False
        #: The announcement, the latest status, the obstacles (the world's latched scenery)
        #: and the sources where they were last.
        self.latched: dict[str, bytes] = {}
        self.announced: tuple[int, int] | None = None  # (episode, start_ns) of the latest
        self.finished: WorldStatus | None = None  # the world's, for the episode announced
        self.reported: tuple[int, int] | None = None  # the episode whose final state we hold
        self.report_pub = self.create_publisher(String, qos.RECORDERS, qos.RECORDERS_QOS)
        # The latched topics are kept for late joiners; a metric sample and the robots'
        # states have no stamp; every other topic forwarded is stamped.
        handlers = {qos.EPISODE: self._on_episode, qos.STATUS: self._on_latched,
                    qos.OBSTACLES: self._on_latched, qos.SOURCES: self._on_latched,
                    qos.ROBOT_STATES: self._on_states}
        for topic, msgtype in forwarded.items():
            handler = handlers.get(topic) or (
                self._on_unstamped if qos.topic_of(topic).per_metric else self._on_stamped)
            self._subscribe(qos.message_class(msgtype), topic, qos.profile_for(topic), handler)
        self.create_timer(1.0, self._repeat, clock=Clock(clock_type=ClockType.STEADY_TIME))
        self.get_logger().info(f'live view on {self.server.url}')
        self._ready_timer = self.create_timer(0.1, self._check_ready,
                                              clock=Clock(clock_type=ClockType.STEADY_TIME))

    def _subscribe(self, msg_class: type, topic: str, profile, callback) -> None:
        self.topic_subscriptions[topic] = self.create_subscription(
            msg_class, topic, lambda data, t=topic: callback(t, data), profile, raw=True)

    def _check_ready(self) -> None:
        """Say so once the world's stepped topics (volatile: nothing is kept for a late
        subscriber) reach us; the launcher waits for it before an episode can start."""
        if all(self.topic_subscriptions[topic].get_publisher_count() > 0
               for topic in STEPPED):
            self.destroy_timer(self._ready_timer)
            self.get_logger().info(f'{LIVE_READY} ({", ".join(STEPPED)} matched)')

    def _due(self, topic: str) -> bool:
        """Whether a message of ``topic`` goes out now (the frequent ones are thinned)."""
        if not self.server.wanted(topic):
            return False
        interval = self.min_interval.get(topic)
        if interval is None:
            return True
        now = time.monotonic()
        if now - self.last_sent.get(topic, -interval) < interval:
            return False
        self.last_sent[topic] = now
        return True

    def _on_stamped(self, topic: str, data: bytes) -> None:
        stamp = message_stamp(topic, data)
        if stamp > self.sim_ns:
            self.sim_ns = stamp
            self.server.set_time(stamp)
        self.latest[topic] = (stamp, bytes(data))
        if self._due(topic):
            self.server.publish(topic, stamp, bytes(data))
        if topic == qos.POSES:
            self._report_final_state()

    def _on_unstamped(self, topic: str, data: bytes) -> None:
        # A metric sample is published just after the pose that completes it: the latest
        # sim time is that pose's, within a sample period of the sample's own time.
        self.latest[topic] = (self.sim_ns, bytes(data))
        self.server.publish(topic, self.sim_ns, bytes(data))

    def _on_states(self, topic: str, data: bytes) -> None:
        # Published just before the poses they go with: at the latest sim time, thinned.
        self.latest[topic] = (self.sim_ns, bytes(data))
        if self._due(topic):
            self.server.publish(topic, self.sim_ns, bytes(data))

    def _on_latched(self, topic: str, data: bytes) -> None:
        self.latched[topic] = bytes(data)
        self.server.publish(topic, self.sim_ns, bytes(data))
        if topic == qos.STATUS:
            self._on_status(bytes(data))

    def _on_status(self, data: bytes) -> None:
        try:
            status = WorldStatus.from_json(data[8:].rstrip(b'\x00').decode())
        except ContractError as error:
            self.get_logger().warning(str(error), throttle_duration_sec=5.0)
            return
        if status.state is WorldState.FINISHED:
            self.finished = status
            self._report_final_state()

    def _report_final_state(self) -> None:
        """Say on /recorders, once, that we hold the announced episode's final state: its
        finished status and the poses of its last step (published just before that status)."""
        if self.announced is None or self.finished is None or self.reported == self.announced:
            return
        episode, start_ns = self.announced
        poses = self.latest.get(qos.POSES)
        if self.finished.episode != episode or poses is None \
                or poses[0] < self.finished.time_ns:
            return
        self.reported = self.announced
        self.report_pub.publish(String(data=RecorderReport(
            LIVE_RECORDER, episode, start_ns, RecorderState.CLOSED,
            recorded_ns=self.finished.time_ns, complete=True, path=self.server.url).to_json()))

    def _on_episode(self, topic: str, data: bytes) -> None:
        document = json.loads(bytes(data)[8:].rstrip(b'\x00').decode())
        if document.get('shutdown'):
            self._linger()
            return
        self.latched[topic] = bytes(data)
        self.server.publish(topic, int(document.get('start_ns', self.sim_ns)), bytes(data))
        self.announced = int(document.get('episode', -1)), int(document.get('start_ns', 0))
        self._report_final_state()

    def _linger(self) -> None:
        """The run is over: stop now, or keep serving its final state for ``linger``."""
        linger = self.options.linger
        if linger == 0 or self.lingering:
            if linger == 0 and not self.done.done():
                self.get_logger().info('shutdown announced')
                self.done.set_result(0)
            return
        self.lingering = True
        until = 'until stopped' if linger < 0 else f'for {linger:g} s'
        self.get_logger().info(f'shutdown announced: serving the final state on '
                               f'{self.server.url} {until}')
        self._repeat()
        if linger > 0:
            self._linger_timer = self.create_timer(
                linger, self._stop_lingering, clock=Clock(clock_type=ClockType.STEADY_TIME))

    def _stop_lingering(self) -> None:
        self.destroy_timer(self._linger_timer)
        if not self.done.done():
            self.done.set_result(0)

    def _repeat(self) -> None:
        """The latched topics again, for clients that joined since; while lingering, the
        latest message of every topic (the run's final state)."""
        for topic, data in self.latched.items():
            self.server.publish(topic, self.sim_ns, data)
        if self.lingering:
            for topic, (log_ns, data) in self.latest.items():
                if topic not in self.latched:
                    self.server.publish(topic, log_ns, data)


def main(args: list[str] | None = None) -> int:
    """Run the live node until the shutdown announcement or a signal."""
    argv = list(sys.argv if args is None else args)
    parse_node_args(node_parser('live_node', __doc__.split('\n')[0],
                                sections={'': LiveNodeParams},
                                statuses={2: 'a bad parameter, or the port is taken'}), argv[1:])
    rclpy.init(args=argv)
    node = None
    status = 1
    try:
        node = LiveNode()
        rclpy.spin_until_future_complete(node, node.done)
        status = node.done.result() if node.done.done() else 0
    except STOPPED as error:
        raise_unless_stopped(error)
        status = 0
    except (ParameterError, RuntimeError) as error:
        rclpy.logging.get_logger('live').fatal(str(error))
        status = 2
    finally:
        if node is not None:
            node.server.stop()
        teardown([node], exit_status=status)
    return status


if __name__ == '__main__':
    sys.exit(main())
