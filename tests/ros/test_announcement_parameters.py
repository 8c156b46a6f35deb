"""A controller node takes part in an announced episode only if the announced ``mona`` and
``controller`` sections are its own as parameters: the shipped file's keys alone (defaults
applied for the rest) are accepted; one real value that differs is refused, naming the key,
and the robot answers no readings, so the world or driver sees it absent."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml
from geometry_msgs.msg import TwistStamped
from rcl_interfaces.msg import Log
from rclpy.node import Node
from sensor_msgs.msg import Image, LaserScan
from std_msgs.msg import Bool, String

from mona_controller.contract import Announcement
from mona_controller.mona import MonaParams
from mona_controller.ros import qos
from mona_controller.ros.controller_node import ControllerNode
from mona_controller.ros.messages import fill_readings, ground_image, proximity_scan, stamp_to_ns

pytestmark = pytest.mark.ros

ROBOT = 0
START_NS = 2_000_000_000
STEP_NS = 32_000_000
SHIPPED = Path(__file__).resolve().parents[2] / 'ros_ws/config/mona_swarm.yaml'


def shipped_sections() -> dict:
    """The ``mona`` and ``controller`` sections exactly as the shipped file spells them."""
    parameters = yaml.safe_load(SHIPPED.read_text())['/**']['ros__parameters']
    return {'mona': dict(parameters['mona']), 'controller': dict(parameters['controller'])}


class World(Node):
    """Announces an episode and sends robot 0's readings; records its answers and errors."""

    def __init__(self, **kwargs) -> None:
        super().__init__('stand_in_world', **kwargs)
        self.episode_pub = self.create_publisher(String, qos.EPISODE, qos.EPISODE_QOS)
        self.ground_pub = self.create_publisher(Image, qos.robot_topic(ROBOT, qos.GROUND),
                                                qos.SENSOR_QOS)
        self.scan_pub = self.create_publisher(LaserScan, qos.robot_topic(ROBOT, qos.PROXIMITY),
                                              qos.SENSOR_QOS)
        self.cmd_sub = self.create_subscription(
            TwistStamped, qos.robot_topic(ROBOT, qos.CMD_VEL),
            lambda msg: self.stamps.append(stamp_to_ns(msg.header.stamp)), qos.COMMAND_QOS)
        # The controller listens only once both its cmd_vel and cleaner are matched.
        self.create_subscription(Bool, qos.robot_topic(ROBOT, qos.CLEANER), lambda msg: None,
                                 qos.CLEANER_QOS)
        self.stamps: list[int] = []
        self.errors: list[str] = []
        self.create_subscription(Log, '/rosout', self._on_log, 100)
        self.ground_msg = ground_image(ROBOT)
        self.scan_msg = proximity_scan(ROBOT, MonaParams())

    def _on_log(self, msg: Log) -> None:
        if msg.name == f'mona_{ROBOT}.mona_controller' and msg.level >= Log.ERROR:
            self.errors.append(msg.msg)

    def connected(self) -> bool:
        return (self.ground_pub.get_subscription_count() > 0
                and self.cmd_sub.get_publisher_count() > 0)

    def announce(self, episode: int, start_ns: int, parameters: dict) -> None:
        self.episode_pub.publish(String(data=Announcement(
            episode, seed=1, population=1, duration=10.0, start_ns=start_ns,
            poses=((1.0, 1.0, 0.0),), parameters=parameters).to_json()))

    def send(self, stamp_ns: int) -> None:
        fill_readings(self.ground_msg, self.scan_msg, np.array([100, 100], dtype=np.uint8),
                      np.full(5, np.inf, dtype=np.float32), np.zeros(5, dtype=bool), stamp_ns)
        self.ground_pub.publish(self.ground_msg)
        self.scan_pub.publish(self.scan_msg)


@pytest.fixture
def pair(executor, spin_until):
    controller = ControllerNode(ROBOT, context=executor.context)
    world = World(context=executor.context)
    executor.add_node(controller)
    executor.add_node(world)
    spin_until(world.connected, what='controller and world connected')
    return controller, world


def test_the_shipped_keys_alone_are_accepted_and_one_differing_value_is_refused(
        pair, spin_until, executor):
    controller, world = pair
    sections = shipped_sections()
    assert 'turn_at' not in sections['controller']  # the file leaves keys at their defaults
    world.announce(0, START_NS, sections)
    spin_until(lambda: controller.episode is not None, what='announcement 0')
    world.send(START_NS)
    spin_until(lambda: START_NS in world.stamps, what='the accepted episode answered')
    assert controller.active and world.errors == []

    # Episode 1 announces another IR range and gain: refused, naming the keys with both
    # values (a kind's section too).
    sections['mona']['ir_range'] = 0.05
    sections['controller']['beeclust']['alpha'] = 2.5
    start = START_NS + 100 * STEP_NS
    world.announce(1, start, sections)
    spin_until(lambda: controller.episode.episode == 1, what='announcement 1')
    spin_until(lambda: world.errors, what='the refusal logged')
    assert 'episode 1 refused' in world.errors[-1]
    assert 'mona.ir_range: announced 0.05, here 0.03' in world.errors[-1]
    assert 'controller.beeclust.alpha: announced 2.5, here 2.0' in world.errors[-1]
    assert not controller.active
    for k in range(5):  # the readings a world sends go unanswered: the robot is absent
        world.send(start + k * STEP_NS)
    for _ in range(40):
        executor.spin_once(timeout_sec=0.025)
    assert [s for s in world.stamps if s >= start] == []

    # Episode 2 is the shipped file again: the robot takes part again.
    start2 = start + 100 * STEP_NS
    world.announce(2, start2, shipped_sections())
    spin_until(lambda: controller.episode.episode == 2, what='announcement 2')
    world.send(start2)
    spin_until(lambda: start2 in world.stamps, what='episode 2 answered')
    assert controller.active
