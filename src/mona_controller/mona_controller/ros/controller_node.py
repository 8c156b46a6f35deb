"""The controller node: one Mona's controller behind its ground, proximity and cmd_vel topics.

A thin adapter: :mod:`~mona_controller.ros.messages` converts the messages,
:class:`~mona_controller.pairing.ReadingPairs` pairs the readings by stamp and answers repeats,
the controller of one robot, of the kind ``controller.kind`` names (built by
:func:`~mona_controller.controllers.base.make_controller`), computes new answers at
``now = (stamp_ns - start_ns) / 1e9``, as the embedded runner does. Each ``/episode`` resets
it from ``(seed, robot_id)``. ``--robots 0-9`` hosts several robots' nodes in one process.
"""

from __future__ import annotations

import dataclasses
import re
import sys
from collections.abc import Sequence

import numpy as np
import rclpy
from geometry_msgs.msg import TwistStamped
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.task import Future
from sensor_msgs.msg import Image, LaserScan
from std_msgs.msg import Bool, String, UInt8

from mona_controller.contract import Announcement, ContractError
from mona_controller.controllers.base import Controller, make_controller
from mona_controller.controllers.params import ControllerParams
from mona_controller.mappings import differences
from mona_controller.mona import MonaParams, wheels_to_twist
from mona_controller.node_help import node_parser, parse_node_args
from mona_controller.pairing import RateLimitedLog, ReadingPairs
from mona_controller.ros import qos
from mona_controller.ros.messages import (
    ReadingError,
    fill_twist,
    ground_from_image,
    proximity_from_scan,
    stamp_to_ns,
)
from mona_controller.ros.ros_params import declare_plugins, declare_section
from mona_controller.ros.shutdown import STOPPED, raise_unless_stopped, teardown
from mona_controller.ros.spinning import spin_until
from mona_controller.schema import ParameterError, param, validate

#: Wall seconds between checks that a world (or driver) listens to our commands.
LISTEN_POLL = 0.02

#: The answer to a pair of readings: (cleaner, linear m/s, angular rad/s, the controller's
#: state after it).
Answer = tuple[bool, float, float, int]


@dataclasses.dataclass(frozen=True)
class ControllerNodeParams:
    """Options of the controller node itself (not part of the model)."""

    robot_id: int = param(-1, low=-1, high=99999,
                          doc='the robot this node controls; -1 takes it from the namespace '
                              '/mona_<id>')

    def __post_init__(self) -> None:
        validate(self)


def robot_id_of(namespace: str, requested: int) -> int:
    """The robot id from the ``robot_id`` parameter or the namespace ``/mona_<id>``."""
    match = re.fullmatch(r'/mona_(\d+)', namespace)
    if requested >= 0:
        if match is None or int(match.group(1)) != requested:
            raise ParameterError(f'robot_id = {requested} needs the namespace '
                                 f'{qos.robot_namespace(requested)}, the node runs in '
                                 f'{namespace!r}: start it with --robots {requested} or '
                                 f'--ros-args -r __ns:={qos.robot_namespace(requested)}')
        return requested
    if match is None:
        raise ParameterError(f'robot_id is not set and the namespace {namespace!r} is not '
                             '/mona_<id>: start the node with --robots <id> or --ros-args -r '
                             '__ns:=/mona_<id>')
    return int(match.group(1))


class ControllerNode(Node):
    """The controller of one Mona (namespace ``/mona_<robot_id>``)."""

    def __init__(self, robot_id: int | None = None, *,
                 parameter_overrides: Sequence[Parameter] = (), **kwargs) -> None:
        overrides = [Parameter('use_sim_time', value=True), *parameter_overrides]
        namespace = None
        if robot_id is not None:
            overrides.append(Parameter('robot_id', value=robot_id))
            namespace = qos.robot_namespace(robot_id)
        super().__init__('mona_controller', namespace=namespace, parameter_overrides=overrides,
                         **kwargs)
        declare_plugins(self)  # before controller.kind, which may name a plug-in's kind
        options = declare_section(self, ControllerNodeParams)
        self.robot_id = robot_id_of(self.get_namespace(), options.robot_id)
        self.mona = declare_section(self, MonaParams, 'mona.')
        self.params = declare_section(self, ControllerParams, 'controller.')
        self.controller: Controller = make_controller(self.params, self.mona, [self.robot_id])

        self.finished = Future()  #: done when the supervisor announces the shutdown
        self.episode: Announcement | None = None  #: the current episode, None before the first
        self.active = False  # this robot takes part in the current episode
        self.pairs = ReadingPairs(self._answer)  # readings by stamp, None = malformed
        self.warn = RateLimitedLog(lambda text: self.get_logger().warning(f'bad input: {text}'))

        self.cleaner_msg = Bool()
        self.state_msg = UInt8()
        self.twist_msg = TwistStamped()
        self.twist_msg.header.frame_id = qos.base_frame(self.robot_id)
        quiet_pub, quiet_sub = qos.QUIET_PUBLISHER, qos.QUIET_SUBSCRIPTION
        self.cleaner_pub = self.create_publisher(Bool, qos.CLEANER, qos.CLEANER_QOS,
                                                 event_callbacks=quiet_pub)
        self.state_pub = self.create_publisher(UInt8, qos.STATE, qos.STATE_QOS,
                                               event_callbacks=quiet_pub)
        self.cmd_pub = self.create_publisher(TwistStamped, qos.CMD_VEL, qos.COMMAND_QOS,
                                             event_callbacks=quiet_pub)
        self.create_subscription(String, qos.EPISODE, self.on_episode, qos.EPISODE_QOS,
                                 event_callbacks=quiet_sub)
        # Listen to readings only once the answers can be delivered: the world starts a step
        # when it sees our readings subscriptions, and an answer sent before our writer has
        # matched its reader would arrive seconds late (a miss).
        self.listen_timer = self.create_timer(LISTEN_POLL, self._listen_when_heard,
                                              clock=Clock(clock_type=ClockType.STEADY_TIME))

    def _listen_when_heard(self) -> None:
        if self.cmd_pub.get_subscription_count() == 0 or \
                self.cleaner_pub.get_subscription_count() == 0:
            return
        self.destroy_timer(self.listen_timer)
        quiet_sub = qos.QUIET_SUBSCRIPTION
        self.create_subscription(Image, qos.GROUND, self.on_ground, qos.SENSOR_QOS,
                                 event_callbacks=quiet_sub)
        self.create_subscription(LaserScan, qos.PROXIMITY, self.on_proximity, qos.SENSOR_QOS,
                                 event_callbacks=quiet_sub)
        self.get_logger().info(f'robot {self.robot_id} connected to a world')

    def on_episode(self, msg: String) -> None:
        """Reset for a new episode, or finish on the shutdown announcement."""
        try:
            announcement = Announcement.from_json(msg.data)
        except ContractError as error:
            self.get_logger().error(f'ignoring the /episode announcement: {error}')
            return
        if announcement.shutdown:
            self.get_logger().info('shutdown announced')
            if not self.finished.done():
                self.finished.set_result(True)
            return
        if self.episode is not None and self.episode.key == announcement.key:
            return  # the same announcement again (e.g. redelivered): keep the state
        self.episode = announcement
        refused = self._parameter_differences(announcement.parameters)
        self.active = self.robot_id < announcement.population and not refused
        self.controller.reset(announcement.seed)
        if refused:
            # Refused: this robot takes no part (it answers no readings), so the world or
            # driver sees it absent; the reason is logged once per episode.
            self.get_logger().error(
                f'episode {announcement.episode} refused: the episode announces other '
                'parameters than this node runs: ' + '; '.join(refused)
                + ': start every node with the same --params-file; this robot takes no part')
        self.get_logger().info(f'episode {announcement.episode}: seed {announcement.seed}, '
                               f'start {announcement.start_ns} ns, '
                               + ('refused' if refused else
                                  f'active ({self.params.kind})' if self.active
                                  else 'not in this population'))
        self._publish(self.pairs.start(announcement.start_ns))

    def _parameter_differences(self, announced: dict) -> list[str]:
        """The announced ``mona`` and ``controller`` keys whose values differ from this node's,
        as parameters (defaults applied: a file that leaves a key at its default runs the same
        model as one that spells it out), one line per key with both values."""
        differ: list[str] = []
        for section, mine in (('mona', self.mona), ('controller', self.params)):
            theirs = announced.get(section)
            if theirs is not None:
                differ += differences(mine, theirs, f'{section}.')
        return differ

    def on_ground(self, msg: Image) -> None:
        """A ground-sensor image: the two readings, or a one-line warning if it is malformed."""
        try:
            ground = ground_from_image(msg).reshape(1, 2)
        except ReadingError as error:
            self.warn('ground', str(error))
            ground = None
        self._publish(self.pairs.add_ground(stamp_to_ns(msg.header.stamp), ground))

    def on_proximity(self, msg: LaserScan) -> None:
        """An IR scan: the ranges and robot flags, or a one-line warning if it is malformed."""
        try:
            ranges, is_robot, note = proximity_from_scan(msg, self.mona.ir_count)
            if note:
                self.warn('repaired', note)
            scan = (ranges.reshape(1, -1), is_robot.reshape(1, -1))
        except ReadingError as error:
            self.warn('proximity', str(error))
            scan = None
        self._publish(self.pairs.add_proximity(stamp_to_ns(msg.header.stamp), scan))

    def _answer(self, stamp: int, ground: np.ndarray | None,
                scan: tuple[np.ndarray, np.ndarray] | None) -> Answer | None:
        """The command for new readings (None: this robot is not in the episode)."""
        if not self.active:
            return None
        if ground is None or scan is None:
            return False, 0.0, 0.0, int(self.controller.state[0])  # unusable: hold still
        now = (stamp - self.episode.start_ns) / 1e9
        command = self.controller.step(ground, scan[0], scan[1], now)
        linear, angular = wheels_to_twist(command.wheels, self.mona)
        return (bool(command.cleaner[0]), float(linear[0]), float(angular[0]),
                int(self.controller.state[0]))

    def _publish(self, answers: list[tuple[int, Answer | None]]) -> None:
        """Send each answer: ``state``, ``cleaner``, then ``cmd_vel`` stamped with the
        readings' stamp (the world takes the state and the cleaner as they are when the
        command arrives)."""
        for stamp, answer in answers:
            if answer is None:
                continue
            cleaner, linear, angular, state = answer
            self.state_msg.data = state
            self.state_pub.publish(self.state_msg)
            self.cleaner_msg.data = cleaner
            self.cleaner_pub.publish(self.cleaner_msg)
            if not fill_twist(self.twist_msg, stamp, linear, angular):
                self.warn('command', f'non-finite command ({linear}, {angular}) replaced by a '
                          'stop')
            self.cmd_pub.publish(self.twist_msg)


def parse_robots(spec: str) -> list[int]:
    """Robot ids from ``'3'``, ``'0-9'`` or ``'0,2,5-7'``."""
    ids: list[int] = []
    for part in spec.split(','):
        first, _, last = part.strip().partition('-')
        if not first.isdigit() or (last and not last.isdigit()):
            raise ParameterError(f'--robots {spec!r}: expected ids like 3, 0-9 or 0,2,5-7')
        ids.extend(range(int(first), int(last or first) + 1))
    if not ids or len(set(ids)) != len(ids):
        raise ParameterError(f'--robots {spec!r}: expected distinct robot ids')
    return ids


def main(args: Sequence[str] | None = None) -> int:
    """Entry point ``mona_controller_node [--robots IDS] [--ros-args ...]``."""
    argv = list(sys.argv if args is None else args)
    parser = node_parser('mona_controller_node', __doc__.split('\n')[0], sections={
        '': ControllerNodeParams, 'controller.': ControllerParams, 'mona.': MonaParams})
    parser.add_argument('--robots', help='robot ids hosted by this process as separate nodes '
                        '(3, 0-9, 0,2,5-7); default: one robot from robot_id or the namespace')
    options = parse_node_args(parser, argv[1:])  # --help: before any node starts
    rclpy.init(args=argv)
    logger = rclpy.logging.get_logger('mona_controller')
    nodes: list[ControllerNode] = []
    status = 1  # an exception that escapes is a failure, also if teardown then hangs
    try:
        ids = parse_robots(options.robots) if options.robots else [None]
        nodes.extend(ControllerNode(robot_id) for robot_id in ids)
        spin_until(nodes, lambda: all(node.finished.done() for node in nodes))
        status = 0
    except STOPPED as error:
        raise_unless_stopped(error)
        status = 0
    except ParameterError as error:
        logger.fatal(f'bad parameter: {error}')
        status = 2
    finally:
        teardown(nodes, exit_status=status)
    return status


if __name__ == '__main__':
    sys.exit(main())
