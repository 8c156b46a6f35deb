"""The messaging ceiling of a lockstep round: bare rclpy ping-pong over the per-robot topics.

One central process plays the world: each round it publishes every robot's ``ground``
(Image 1 x 2) and ``proximity`` (LaserScan, 5 beams) stamped with the round's time, then spins
until every robot has answered with ``cleaner`` (Bool) and ``cmd_vel`` (TwistStamped, the same
stamp). Each responder process plays controllers: it answers a (ground, proximity) pair and
does nothing else. Same topics, message types and QoS as docs/interfaces.md, no model.

Used by bench/bench_lockstep.py; runs alone too:

    .venv/bin/python bench/pingpong.py --population 50 --rounds 500
"""

from __future__ import annotations

import argparse
import math
import os
import signal
import subprocess
import sys
import time

import rclpy
from geometry_msgs.msg import TwistStamped
from rclpy.executors import ExternalShutdownException
from rclpy.experimental.events_executor import EventsExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import Image, LaserScan
from std_msgs.msg import Bool

SENSOR_QOS = QoSProfile(depth=5, reliability=ReliabilityPolicy.RELIABLE,
                        durability=DurabilityPolicy.VOLATILE)
LATCHED_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)
STEP_NS = 32_000_000


class Responder(Node):
    """One robot's stand-in controller: answers each sensor pair with a Bool and a twist."""

    def __init__(self, robot: int) -> None:
        super().__init__('pong', namespace=f'mona_{robot}')
        self._stamps = {'ground': -1, 'proximity': -1}  # the latest stamp of each half
        self._answered = -1
        self._cleaner = self.create_publisher(Bool, 'cleaner', LATCHED_QOS)
        self._cmd = self.create_publisher(TwistStamped, 'cmd_vel', SENSOR_QOS)
        self._answer = TwistStamped()
        self._answer.twist.linear.x = 0.08
        self.create_subscription(Image, 'ground', lambda m: self._on_half('ground', m),
                                 SENSOR_QOS)
        self.create_subscription(LaserScan, 'proximity', lambda m: self._on_half('proximity', m),
                                 SENSOR_QOS)

    def _on_half(self, half: str, msg: Image | LaserScan) -> None:
        """Answer once both halves of a stamp are in (the two topics may arrive in any order)."""
        stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        self._stamps[half] = stamp
        if self._stamps['ground'] == self._stamps['proximity'] != self._answered:
            self._answered = stamp
            self._cleaner.publish(Bool(data=False))
            self._answer.header.stamp = msg.header.stamp
            self._cmd.publish(self._answer)


class Central(Node):
    """The world's stand-in: one lockstep round = publish 2N, wait for 2N answers."""

    def __init__(self, population: int, **kwargs) -> None:
        super().__init__('ping', **kwargs)
        self.population = population
        self._ground = [self.create_publisher(Image, f'/mona_{i}/ground', SENSOR_QOS)
                        for i in range(population)]
        self._proximity = [self.create_publisher(LaserScan, f'/mona_{i}/proximity', SENSOR_QOS)
                           for i in range(population)]
        self._answers = [self.create_subscription(
            TwistStamped, f'/mona_{i}/cmd_vel', lambda msg, i=i: self._on_cmd(i, msg),
            SENSOR_QOS) for i in range(population)]
        self._cleaners = [self.create_subscription(Bool, f'/mona_{i}/cleaner',
                                                   self._on_cleaner, LATCHED_QOS)
                          for i in range(population)]
        self.stamp_ns = 0
        self.answered: set[int] = set()

    def _on_cmd(self, robot: int, msg: TwistStamped) -> None:
        if msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec == self.stamp_ns:
            self.answered.add(robot)

    def _on_cleaner(self, msg: Bool) -> None:
        pass

    def connected(self) -> int:
        """Robots whose four topics are matched both ways."""
        return sum(g.get_subscription_count() > 0 and p.get_subscription_count() > 0
                   and a.get_publisher_count() > 0
                   for g, p, a in zip(self._ground, self._proximity, self._answers))

    def publish_round(self, stamp_ns: int) -> None:
        self.stamp_ns = stamp_ns
        self.answered.clear()
        for i in range(self.population):
            ground = Image(height=1, width=2, encoding='mono8', step=2, data=[128, 130])
            ground.header.stamp.sec, ground.header.stamp.nanosec = divmod(stamp_ns, 10**9)
            ground.header.frame_id = f'mona_{i}/base_link'
            scan = LaserScan(angle_min=-1.2217, angle_max=1.2217, angle_increment=0.6109,
                             range_min=0.0, range_max=0.03, ranges=[math.inf] * 5,
                             intensities=[0.0] * 5)
            scan.header = ground.header
            self._ground[i].publish(ground)
            self._proximity[i].publish(scan)


def run_central(population: int, rounds: int, timeout: float = 120.0,
                context: rclpy.Context | None = None) -> dict[str, float]:
    """Wait for every responder, then time ``rounds`` lockstep rounds.

    Returns rounds per second and the discovery time; raises RuntimeError if not every robot
    connects within ``timeout`` wall seconds or a round stalls for 10 s.
    """
    node = Central(population, context=context)
    executor = EventsExecutor(context=context)  # as the system's nodes (ros/spinning.py)
    executor.add_node(node)
    try:
        started = time.monotonic()
        while node.connected() < population:
            if time.monotonic() - started > timeout:
                raise RuntimeError(f'only {node.connected()} of {population} responders '
                                   f'connected after {timeout:.0f} s')
            executor.spin_once(timeout_sec=0.1)
        discovery = time.monotonic() - started

        def one_round(k: int) -> None:
            node.publish_round((k + 1) * STEP_NS)
            deadline = time.monotonic() + 10.0
            while len(node.answered) < population:
                if time.monotonic() > deadline:
                    raise RuntimeError(f'round {k}: {len(node.answered)} of {population} '
                                       'answers after 10 s')
                executor.spin_once(timeout_sec=0.5)

        for k in range(20):  # warm-up: matching settles, caches fill
            one_round(k)
        t0 = time.perf_counter()
        for k in range(20, 20 + rounds):
            one_round(k)
        wall = time.perf_counter() - t0
        return {'rounds_per_s': rounds / wall, 'discovery_s': discovery, 'wall_s': wall}
    finally:
        executor.shutdown()
        node.destroy_node()


def run_responders(robots: list[int]) -> None:
    """Spin one responder node per robot in this process until SIGINT/SIGTERM."""
    rclpy.init()
    signal.signal(signal.SIGTERM, lambda *_: rclpy.try_shutdown())
    executor = EventsExecutor()
    nodes = [Responder(i) for i in robots]
    for node in nodes:
        executor.add_node(node)
    try:
        while True:  # spin() and spin_once() without a timeout can block for good
            executor.spin_once(timeout_sec=1.0)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        for node in nodes:
            node.destroy_node()
        rclpy.try_shutdown()


def spawn_responders(population: int, per_process: int = 1) -> list[subprocess.Popen]:
    """Start the responder processes (each in its own process group)."""
    processes = []
    for first in range(0, population, per_process):
        robots = [str(i) for i in range(first, min(first + per_process, population))]
        processes.append(subprocess.Popen(
            [sys.executable, __file__, '--responders', *robots], start_new_session=True,
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
    return processes


def stop(processes: list[subprocess.Popen]) -> None:
    """SIGINT, then SIGKILL whatever is still alive after 10 s."""
    for process in processes:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGINT)
    deadline = time.monotonic() + 10.0
    for process in processes:
        try:
            process.wait(max(0.1, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--population', type=int, default=50)
    parser.add_argument('--rounds', type=int, default=500)
    parser.add_argument('--controllers-per-process', type=int, default=1)
    parser.add_argument('--responders', type=int, nargs='+', help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.responders is not None:
        run_responders(args.responders)
        return
    processes = spawn_responders(args.population, args.controllers_per_process)
    rclpy.init()
    try:
        result = run_central(args.population, args.rounds)
    finally:
        rclpy.try_shutdown()
        stop(processes)
    print(f'ping-pong, N = {args.population}: {result["rounds_per_s"]:.1f} rounds/s '
          f'(discovery {result["discovery_s"]:.1f} s)')


if __name__ == '__main__':
    main()
