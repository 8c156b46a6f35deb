"""A deliberately broken world for the suite's self-test: the world node behind a relay that
reverses every robot's beam order (left to right), all else untouched.

    python reversed_beams.py --population N -- world_node --ros-args --params-file P ...

The world's ``/mona_<i>/proximity`` is remapped to ``/unrelayed/mona_<i>/proximity``; this
process republishes each scan on ``/mona_<i>/proximity`` with ``ranges`` and ``intensities``
reversed. It exits with the world's status and passes SIGINT / SIGTERM on to it. The fault
lives here, outside the production code, which has no fault switch.
"""

from __future__ import annotations

import argparse
import signal
import subprocess
import sys

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import LaserScan

SENSOR_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=5,
                        reliability=ReliabilityPolicy.RELIABLE,
                        durability=DurabilityPolicy.VOLATILE)


class ReversingRelay(Node):
    """Relays each robot's scan with its beams in the wrong order."""

    def __init__(self, population: int, world: subprocess.Popen) -> None:
        super().__init__('reversed_beams_relay')
        self.world = world
        self.status: int | None = None
        for robot in range(population):
            publisher = self.create_publisher(LaserScan, f'/mona_{robot}/proximity', SENSOR_QOS)
            self.create_subscription(LaserScan, f'/unrelayed/mona_{robot}/proximity',
                                     lambda msg, pub=publisher: self.relay(msg, pub),
                                     SENSOR_QOS)
        self.create_timer(0.1, self.watch)

    def relay(self, msg: LaserScan, publisher) -> None:
        msg.ranges = list(reversed(msg.ranges))
        msg.intensities = list(reversed(msg.intensities))
        publisher.publish(msg)

    def watch(self) -> None:
        self.status = self.world.poll()


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--population', type=int, required=True)
    parser.add_argument('world', nargs=argparse.REMAINDER, help='-- the world command line')
    args = parser.parse_args()
    command = [part for part in args.world if part != '--'][:]
    if not command:
        parser.error('no world command after --')
    if '--ros-args' not in command:
        command.append('--ros-args')
    for robot in range(args.population):
        command += ['-r', f'/mona_{robot}/proximity:=/unrelayed/mona_{robot}/proximity']
    world = subprocess.Popen(command)
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda number, frame: world.send_signal(number))
    rclpy.init()
    relay = ReversingRelay(args.population, world)
    try:
        while relay.status is None:
            rclpy.spin_once(relay, timeout_sec=0.1)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        relay.destroy_node()
        rclpy.try_shutdown()
    return world.wait()


if __name__ == '__main__':
    sys.exit(main())
