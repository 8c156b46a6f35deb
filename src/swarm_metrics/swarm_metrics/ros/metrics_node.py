"""The metrics node: online metrics on /metrics/<name> and one bag per episode.

A thin adapter around :class:`swarm_metrics.bags.recording.Recorder`, which keeps a replica of the
cue by applying each /world/cleaning event with the world's own cleaning function, samples
the metrics once per ``sample_period`` of sim time and records them, so the online numbers
and ``mona-swarm analyze`` on the bag agree by construction.

Each announced episode k gets the bag ``<output_dir>/episode_<k>/bag`` (rosbag2 layout, MCAP,
zstd). Messages are recorded as the CDR bytes that arrived (raw subscriptions), log time = the
sim time they describe. Exit status: 0 after the supervisor's shutdown announcement or
SIGINT/SIGTERM, 3 when the world stops talking while an episode runs, 2 for bad parameters;
the bag is closed on every path.

The node is a *recorder* (docs/interfaces.md, "Recorders"): on /recorders it says when an
episode's bag is open and listening (the world publishes the episode's start only then), how
far its record is whole (the world takes its first step once the start is recorded, and
never runs more than ``recorder_lag`` ahead), and, when it closes the bag, the completeness
verdict on it (:func:`swarm_metrics.completeness.check_bag`, read back from disk). It closes a
finished episode as soon as everything the world's final status counts has arrived, or after
``finish_timeout``, and judges what it has.
"""

from __future__ import annotations

import dataclasses
import sys
import time
from collections.abc import Callable
from pathlib import Path

import rclpy
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.task import Future
from std_msgs.msg import Float64, String

from mona_controller.contract import RecorderReport, RecorderState
from mona_controller.node_help import node_parser, parse_node_args
from mona_controller.ros import qos
from mona_controller.ros.ros_params import declare_plugins, declare_section
from mona_controller.ros.shutdown import STOPPED, raise_unless_stopped, teardown
from mona_controller.ros.spinning import spin_until
from mona_controller.schema import ParameterError, param, validate
from mona_controller.topics import CONTROLLER, SUPERVISOR, TOPICS, WORLD
from swarm_metrics.bags.record import Closed, Row
from swarm_metrics.bags.recording import Recorder
from swarm_metrics.bags.scan import BagError
from swarm_metrics.bags.writer import CHUNK_PERIOD
from swarm_metrics.metrics import metric_names

EXIT_WORLD_LOST = 3
#: The topics of the other nodes that a default bag records (the node publishes /metrics/*
#: itself).
RECORDED = tuple(name for name, topic in TOPICS.items()
                 if topic.recorded and topic.publisher in (WORLD, SUPERVISOR))
#: What ``record_all`` adds: every other topic of the world and the controllers (per robot
#: ones in each announced robot's namespace).
RECORDED_ALL = tuple(name for name, topic in TOPICS.items()
                     if not topic.recorded and topic.publisher in (WORLD, CONTROLLER))
#: Wall seconds between looks at the world's health and the episode's end.
TICK = 0.1


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


class MetricsNode(Node):
    """Computes the metrics online and records each episode's bag."""

    def __init__(self, **kwargs) -> None:
        super().__init__('metrics', **kwargs)
        declare_plugins(self)  # their metrics and layouts, before any topic or episode
        self.options = declare_section(self, MetricsNodeParams)
        self.done = Future()  #: set to the exit status when the node should stop
        options = self.options
        self.recorder = Recorder(Path(options.output_dir), chunk_period=options.chunk_period,
                                 cue_map_period=options.cue_map_period,
                                 clock_period=options.clock_period,
                                 record_all=options.record_all)
        self.metric_pubs = {name: self.create_publisher(Float64, qos.metric_topic(name),
                                                        qos.METRICS_QOS)
                            for name in metric_names()}
        self.report_pub = self.create_publisher(String, qos.RECORDERS, qos.RECORDERS_QOS)
        #: What the node does with each topic it records (:data:`RECORDED`, in subscription
        #: order; then :data:`RECORDED_ALL`'s with record_all).
        self.handlers: dict[str, Callable[[str, bytes], object]] = {
            qos.EPISODE: self._on_episode, qos.STATUS: self._on_status,
            qos.POSES: self._on_world, qos.CLEANING: self._on_world,
            qos.CUE_MAP: self._on_world, qos.CLOCK: self.recorder.periodic,
            qos.OBSTACLES: self._on_obstacles, qos.ROBOT_STATES: self._on_states,
            qos.SOURCES: self._on_sources,
            qos.CUE_GRID: self.recorder.stamped, qos.MARKERS: self._on_unstamped,
            qos.GROUND: self.recorder.stamped, qos.PROXIMITY: self.recorder.stamped,
            qos.CMD_VEL: self.recorder.stamped, qos.CLEANER: self._on_unstamped,
            qos.STATE: self._on_unstamped}
        subscriptions = {topic: self._subscribe(topic) for topic in self.handlers
                         if topic in RECORDED or (options.record_all and topic in RECORDED_ALL
                                                  and not TOPICS[topic].per_robot)}
        # Volatile: no history for a late joiner, so these must be matched before step 0.
        self.world_subscriptions = [subscriptions[qos.POSES], subscriptions[qos.CLEANING],
                                    subscriptions[qos.ROBOT_STATES]]
        self._robot_subscriptions: set[int] = set()
        self._confirmed = False  # the open episode's "recording" report is out
        self._reported_ns: int | None = None  # the recorded_ns of the latest such report
        self._closing_at: float | None = None  # wall time to give up on the episode's rest
        self._shutdown_requested = False
        self._last_world = self._last_tick = time.monotonic()
        # Wall time, so a stalled /clock cannot stall the watchdog.
        self.create_timer(TICK, self._tick, clock=Clock(clock_type=ClockType.STEADY_TIME))
        self.get_logger().info(f'recording episodes into {options.output_dir} '
                               f'(record_all={options.record_all})')

    def _subscribe(self, name: str, robot_id: int | None = None):
        """A raw subscription to a topic of the table (per robot: in robot ``robot_id``'s
        namespace), with its type and QoS, calling its handler with (topic, data)."""
        entry, callback = TOPICS[name], self.handlers[name]
        topic = name if robot_id is None else qos.robot_topic(robot_id, name)
        return self.create_subscription(qos.message_class(entry.type), topic,
                                        lambda data, t=topic: callback(t, data),
                                        qos.PROFILES[name], raw=True)

    def _subscribe_robots(self, population: int) -> None:
        """record_all: every robot's sensor and command topics."""
        for i in set(range(population)) - self._robot_subscriptions:
            self._robot_subscriptions.add(i)
            for name in RECORDED_ALL:
                if TOPICS[name].per_robot:
                    self._subscribe(name, i)

    # --- what the node says ------------------------------------------------------------

    def _publish(self, rows: list[Row]) -> None:
        """Publish metric rows, then tell the world how far the record is whole."""
        for _, row in rows:
            for name, publisher in self.metric_pubs.items():
                publisher.publish(Float64(data=float(row[name])))
        self._progress()

    def _progress(self) -> None:
        """Repeat the "recording" report when the record is whole further than it said (a
        new sample; the episode's start recorded): the world holds until it is."""
        episode = self.recorder.episode
        if self._confirmed and episode is not None and \
                episode.recorded_ns != self._reported_ns:
            self._report(RecorderState.RECORDING)

    def _report(self, state: RecorderState, closed: Closed | None = None) -> None:
        """Say on /recorders what this recorder does with the episode (open or ``closed``)."""
        if closed is not None:
            report = RecorderReport(self.get_name(), closed.episode, closed.start_ns, state,
                                    complete=closed.complete, problems=closed.problems,
                                    path=str(closed.path))
        else:
            episode = self.recorder.episode
            self._reported_ns = episode.recorded_ns
            report = RecorderReport(self.get_name(), episode.setup.episode,
                                    episode.setup.start_ns, state, episode.recorded_ns,
                                    path=str(episode.bag.path))
        self.report_pub.publish(String(data=report.to_json()))

    def _confirm(self) -> None:
        """Say "recording" once the bag is open and the world's poses, states and cleaning
        events can reach it (matched subscriptions: their topics keep no history for late
        joiners)."""
        if self._confirmed or self.recorder.episode is None:
            return
        if all(s.get_publisher_count() > 0 for s in self.world_subscriptions):
            self._confirmed = True
            self._report(RecorderState.RECORDING)

    def close(self, reason: str, *, publish: bool = True) -> None:
        """Take the last sample, close the bag, judge it and report (safe to call when none
        is open). Without ``publish`` (the node is stopping) the bag is closed unjudged."""
        closed, rows = self.recorder.close(judge=publish)
        self._closing_at, self._confirmed = None, False
        if closed is None:
            return
        if publish:
            self._publish(rows)
            self._report(RecorderState.CLOSED, closed)
        text = f'closed {closed.path} ({closed.messages} messages)'
        if closed.findings is None:
            self.get_logger().warning(f'{text} without a verdict ({reason}): `mona-swarm '
                                      'analyze` judges it')
        elif closed.findings:
            self.get_logger().error(f'{text}, INCOMPLETE: {"; ".join(closed.problems)} '
                                    f'({reason})')
        else:
            self.get_logger().info(f'{text}, complete: {reason}')

    # --- callbacks --------------------------------------------------------------------

    def _on_episode(self, topic: str, data: bytes) -> None:
        try:
            setup, closed, rows, shutdown = self.recorder.announce(data)
        except BagError as error:
            self.get_logger().error(f'ignoring a bad /episode announcement: {error}')
            return
        if closed is not None:
            self.get_logger().error(f'episode {setup.episode} was announced before episode '
                                    f'{closed.episode} ended')
            self._report(RecorderState.CLOSED, closed)
        if setup is not None:
            self._confirmed, self._closing_at = False, None
            self.get_logger().info(f'episode {setup.episode} (seed {setup.seed}, N = '
                                   f'{setup.population}): recording '
                                   f'{self.recorder.episode.bag.path}')
            if self.options.record_all:
                self._subscribe_robots(setup.population)
            self._publish(rows)
            self._confirm()
        elif shutdown and self.recorder.episode is None:  # nothing open: stop now
            self._stop(0)
        elif shutdown:
            # The world's last messages travel on other topics and may still be on their way:
            # close once they are in, or after finish_timeout.
            self._shutdown_requested = True
            if self._closing_at is None:
                self._closing_at = time.monotonic() + self.options.finish_timeout

    def _on_status(self, topic: str, data: bytes) -> None:
        self._last_world = time.monotonic()
        try:
            ended, rows = self.recorder.status(data)
        except BagError as error:
            self.get_logger().warning(str(error))
            return
        self._publish(rows)
        if ended:
            self._closing_at = time.monotonic() + self.options.finish_timeout
            self._close_if_done()

    def _on_world(self, topic: str, data: bytes) -> None:
        """Poses, cleaning events and cue maps."""
        if topic == qos.POSES:
            self._last_world = time.monotonic()
        try:
            self._publish(self.recorder.route(topic, data))
        except BagError as error:
            self.get_logger().error(f'{error}; ignored', throttle_duration_sec=5.0)
        self._close_if_done()

    def _on_obstacles(self, topic: str, data: bytes) -> None:
        self.recorder.obstacles(data)

    def _on_states(self, topic: str, data: bytes) -> None:
        self.recorder.robot_states(data)
        self._progress()
        self._close_if_done()

    def _on_sources(self, topic: str, data: bytes) -> None:
        self.recorder.sources(data)
        self._progress()
        self._close_if_done()

    def _on_unstamped(self, topic: str, data: bytes) -> None:
        self.recorder.write(topic, self.recorder.now_ns, data)

    def _close_if_done(self) -> None:
        if self.recorder.done():
            self._close_episode()

    def _close_episode(self) -> None:
        """Close the ended episode's bag; after the shutdown announcement, stop."""
        final = self.recorder.episode.final if self.recorder.episode else None
        self.close('the supervisor announced the shutdown' if self._shutdown_requested
                   else f'the world {final.state.value if final else "ended"} the episode')
        if self._shutdown_requested:
            self._stop(0)

    def _stop(self, status: int) -> None:
        if not self.done.done():
            self.done.set_result(status)

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
        episode = self.recorder.episode
        if self._closing_at is not None and now >= self._closing_at:
            self._close_episode()
        elif episode is not None and episode.running \
                and now - self._last_world > self.options.world_lost_after:
            self.get_logger().error(f'no /world/status or /world/poses for '
                                    f'{self.options.world_lost_after:g} s while running: the '
                                    f'world is lost')
            self.close('the world was lost')
            self._stop(EXIT_WORLD_LOST)


def main(args: list[str] | None = None) -> int:
    """Run the metrics node until the shutdown announcement, a signal or a lost world."""
    argv = list(sys.argv if args is None else args)
    parse_node_args(node_parser('metrics_node', __doc__.split('\n')[0],
                                sections={'': MetricsNodeParams},
                                statuses={3: 'the world was lost (its bag closed)'}), argv[1:])
    rclpy.init(args=argv)
    node = None
    status = 1  # an exception that escapes is a failure, also if teardown then hangs
    try:
        node = MetricsNode()
        spin_until([node], node.done.done)
        status = node.done.result() if node.done.done() else 0
    except STOPPED as error:
        raise_unless_stopped(error)
        status = 0
    except ParameterError as error:
        rclpy.logging.get_logger('metrics').fatal(f'bad parameter: {error}')
        status = 2
    finally:
        if node is not None:
            node.close('the node is stopping', publish=False)  # durable before teardown
        teardown([node], exit_status=status)
    return status


if __name__ == '__main__':
    sys.exit(main())
