"""Robots 3 and 4 of the conformance scenario, scripted, in a process of their own.

The probe (probe.py) records every topic the world publishes; on a loaded machine that
backlog queued the scripted robots' answers behind it when one executor did both, and a
realtime world, which does not wait, counted robot 3 absent. Here the two robots answer from
their own process, rclpy context and executor: they learn each episode from ``/episode``
(transient local) as a controller does, and do what probe.py's module docstring says, with
its constants. What the rules need to know of them goes to ``--record`` as JSON lines, read
back by the probe (``Probe.take_record``): when a robot subscribed to its readings, every
reading it received (when, and the message), when it answered a step. The readings are
recorded here, not by a subscription of the probe's: each robot's one subscription is the one
the world waits for, made 1 s after the announcement (a second, the probe's, would let the
world start before the robot listens, or before the probe's own proximity subscription
matched, losing it the first readings: seen on the realtime world under load).

The process exits 0 on the shutdown announcement, on SIGINT or SIGTERM, and when its parent
(``--parent``, the process that started it) is gone::

    python tests/conformance/scripted.py --domain D --step-ns N --record FILE --parent PID
"""

from __future__ import annotations

import argparse
import base64
import json
import os
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import IO

import rclpy
from geometry_msgs.msg import TwistStamped
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.serialization import serialize_message
from sensor_msgs.msg import Image, LaserScan
from std_msgs.msg import Bool, String, UInt8

from probe import (
    LISTENER_DEPTH,
    ROBOT3_CLEANS_FROM,
    ROBOT3_DRIVES,
    ROBOT3_LISTENS_AFTER,
    ROBOT3_SLOW_DELAY,
    ROBOT3_SLOW_STEP,
    ROBOT3_SPEED,
    ROBOT3_STEP0_DELAY,
    ROBOT3_WRONG_STEP,
    ROBOT4_CLEANER_STEP,
    ROBOT4_SILENT,
    SCRIPTED,
    init_context,
    ns_of,
    qos,
)

NODE = 'conformance_scripted'


class ScriptedRobots(Node):
    """Answers for robots 3 and 4 as probe.py's module docstring says."""

    def __init__(self, step_ns: int, record: IO[str], parent: int, **kwargs) -> None:
        super().__init__(NODE, **kwargs)
        self.step_ns = step_ns
        self.record = record
        self.parent = parent
        self.clock = time.monotonic  # system-wide: the probe's times compare with these
        self.done = ''  #: why it stops: the shutdown announcement came, the parent is gone
        self.episode: dict | None = None  #: the announcement being played
        self.answered: dict[int, set[int]] = {robot: set() for robot in SCRIPTED}
        self.cmd_pubs = {robot: self.create_publisher(
            TwistStamped, f'/mona_{robot}/cmd_vel', qos(5)) for robot in SCRIPTED}
        self.state_pubs = {robot: self.create_publisher(
            UInt8, f'/mona_{robot}/state', qos(1, latched=True)) for robot in SCRIPTED}
        self.cleaner_pubs = {robot: self.create_publisher(
            Bool, f'/mona_{robot}/cleaner', qos(1, latched=True)) for robot in SCRIPTED}
        self.create_subscription(String, '/episode', self._on_episode, qos(1, latched=True))
        self.create_timer(0.5, self._check_parent)

    def note(self, **item) -> None:
        """One line of the record, written at once (a killed process keeps what it wrote)."""
        self.record.write(json.dumps(item) + '\n')
        self.record.flush()

    def _check_parent(self) -> None:
        if os.getppid() != self.parent:  # it is gone: this process was handed to another
            self.done = 'parent gone'

    def later(self, delay: float, action: Callable[[], None]) -> None:
        """Run ``action`` ``delay`` wall seconds from now (in the executor), once: a timer of
        its own, so the process sleeps in between (no polling)."""
        def once() -> None:
            timer.cancel()
            action()

        timer = self.create_timer(delay, once)

    def _on_episode(self, msg: String) -> None:
        document = json.loads(msg.data)
        if document.get('shutdown'):
            self.done = 'shutdown'
            return
        first = self.episode is None
        self.episode = document
        self.answered = {robot: set() for robot in SCRIPTED}
        if first:  # robots 3 and 4 subscribe to their readings 1 s after the first one
            for robot in SCRIPTED:
                self.later(ROBOT3_LISTENS_AFTER, lambda robot=robot: self._listen(robot))

    def _listen(self, robot: int) -> None:
        self.note(listening=robot, at=self.clock())
        for kind, msg_type in (('ground', Image), ('proximity', LaserScan)):
            self.create_subscription(
                msg_type, f'/mona_{robot}/{kind}',
                lambda msg, robot=robot, kind=kind: self._on_reading(robot, kind, msg),
                qos(LISTENER_DEPTH))

    def _on_reading(self, robot: int, kind: str, msg) -> None:
        received = self.clock()
        if kind == 'ground' and self.episode is not None:
            self._answer(robot, ns_of(msg.header.stamp))  # first: the record can wait
        self.note(reading=[robot, kind], at=received,
                  cdr=base64.b64encode(serialize_message(msg)).decode('ascii'))

    def _answer(self, robot: int, stamp: int) -> None:
        start = self.episode['start_ns']
        step = (stamp - start) // self.step_ns
        if stamp < start or step in self.answered[robot]:
            return  # another episode's, or a repeat we already answered
        self.answered[robot].add(step)
        first = self.episode['episode'] == 0
        if robot == 4 and first and step in ROBOT4_SILENT:
            return
        cleaner = first and ((robot == 3 and step >= ROBOT3_CLEANS_FROM)
                             or (robot == 4 and step == ROBOT4_CLEANER_STEP))
        commands = [(stamp, ROBOT3_SPEED if first and robot == 3 and step in ROBOT3_DRIVES
                         else 0.0)]
        delay = 0.0
        if first and robot == 3:
            if step == 0:
                delay = ROBOT3_STEP0_DELAY
            elif step == ROBOT3_SLOW_STEP:
                delay = ROBOT3_SLOW_DELAY
            elif step == ROBOT3_WRONG_STEP:  # another step's stamp, the answer, a duplicate
                commands = [(stamp + 5 * self.step_ns, 0.0), (stamp, 0.0), (stamp, 0.05)]

        def send() -> None:
            # When the answer began to go out: a reading the world sends only once it has the
            # answer arrives after this. A clock read after the publishing can be later than
            # such a reading's arrival at the probe, if this process is preempted in between
            # (ci33, on a busy machine: by 6 ms).
            began = self.clock()
            for command_stamp, linear in commands:
                if robot == 3:  # robot 4 never says its state: the world keeps 0 for it
                    self.state_pubs[robot].publish(UInt8(data=2 if cleaner else 0))
                self.cleaner_pubs[robot].publish(Bool(data=cleaner))  # then the cleaner
                twist = TwistStamped()
                twist.header.stamp.sec, twist.header.stamp.nanosec = divmod(command_stamp,
                                                                             1_000_000_000)
                twist.header.frame_id = f'mona_{robot}/base_link'
                twist.twist.linear.x = linear
                self.cmd_pubs[robot].publish(twist)
            self.note(sent=[robot, step], at=began)

        if delay:
            self.later(delay, send)
        else:
            send()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--domain', type=int, required=True, help='ROS_DOMAIN_ID')
    parser.add_argument('--step-ns', type=int, required=True, help="the world's step (ns)")
    parser.add_argument('--record', type=Path, required=True, help='JSON lines written here')
    parser.add_argument('--parent', type=int, default=os.getppid(),
                        help='the parent process: exit once it is gone (default: the parent)')
    args = parser.parse_args(argv)
    context = init_context(args.domain)
    executor = SingleThreadedExecutor(context=context)
    with args.record.open('w') as record:
        node = ScriptedRobots(args.step_ns, record, args.parent, context=context)
        executor.add_node(node)
        try:
            while not node.done and context.ok():
                executor.spin_once(timeout_sec=0.1)
        except (KeyboardInterrupt, ExternalShutdownException):
            node.done = 'signal'
        finally:
            node.note(exit=node.done or 'signal')
            executor.remove_node(node)
            node.destroy_node()
            executor.shutdown()
            rclpy.try_shutdown(context=context)
    return 0


if __name__ == '__main__':
    sys.exit(main())
