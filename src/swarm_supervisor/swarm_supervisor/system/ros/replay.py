"""Replay a bag onto its ROS topics (the rclpy half of ``mona-swarm replay``).

Every message is published as its raw CDR bytes on its recorded topic, with the topic's
contract QoS, timed by its log (sim) time divided by the rate, with /clock beside it when the
bag has none.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import rclpy
from builtin_interfaces.msg import Time
from rclpy._rclpy_pybind11 import RCLError
from rclpy.context import Context
from rclpy.qos import QoSProfile
from rosgraph_msgs.msg import Clock

from mona_controller.ros import qos
from mona_controller.schema import ParameterError
from swarm_metrics.bags.scan import McapScan

#: The QoS of a recorded topic the contract does not know.
OTHER_QOS = QoSProfile(depth=10)


def check_ros_environment() -> None:
    """rcl takes this process's ROS environment (``ROS_DOMAIN_ID``, ``RMW_IMPLEMENTATION``,
    ...): a context of its own is started and shut down (no DDS participant yet), so a bad
    variable is refused before the bag is read.

    Raises:
        ParameterError: naming what rcl refused.
    """
    context = Context()
    try:
        rclpy.init(args=[], context=context)
    except RCLError as error:
        reason = str(error).removeprefix('failed to initialize rcl: ').split(', at ')[0]
        raise ParameterError(f'the ROS environment is not usable: {reason}: fix or unset the '
                             'variable') from None
    rclpy.shutdown(context=context)


def play(mcap: Path, topics: dict[str, str], *, rate: float = 1.0,
         delay: float = 1.0) -> tuple[int, int, float, float]:
    """Publish every message of the (checked) bag ``mcap`` whose type is installed.

    Args:
        topics: topic -> message type of the bag.
        rate: sim seconds per wall second (0: as fast as possible).
        delay: seconds to wait for subscribers before playing.

    Returns:
        (messages published, topics published, sim seconds spanned, wall seconds taken).

    Raises:
        BagError: the bag turns out damaged while it plays.
    """
    rclpy.init()
    node = None
    try:
        node = rclpy.create_node('replay')
        publishers, skipped = {}, []
        for topic, msgtype in sorted(topics.items()):
            try:
                msg_class = qos.message_class(msgtype)
            except (ValueError, ImportError, AttributeError):
                skipped.append(topic)
                continue
            profile = qos.profile_for(topic) or OTHER_QOS
            publishers[topic] = node.create_publisher(msg_class, topic, profile)
        clock = None if qos.CLOCK in publishers else node.create_publisher(
            Clock, qos.CLOCK, qos.CLOCK_QOS)
        if skipped:
            print(f'note: not replaying {", ".join(skipped)} (message types not installed)',
                  file=sys.stderr)
        time.sleep(delay)
        count, first, last, clock_ns = 0, None, None, -1
        started = time.monotonic()
        for message in McapScan(mcap):
            publisher = publishers.get(message.topic)
            if publisher is None:
                continue
            first = message.log_time if first is None else first
            last = message.log_time if last is None else max(last, message.log_time)
            if rate > 0:
                wait = started + (message.log_time - first) / 1e9 / rate - time.monotonic()
                if wait > 0:
                    time.sleep(wait)
            if clock is not None and message.log_time > clock_ns:
                clock_ns = message.log_time
                clock.publish(Clock(clock=Time(sec=clock_ns // 10**9,
                                               nanosec=clock_ns % 10**9)))
            publisher.publish(message.data)
            count += 1
        span = 0.0 if first is None else (last - first) / 1e9
        return count, len(publishers), span, time.monotonic() - started
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
