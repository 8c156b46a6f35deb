"""The controller node in this process, driven over DDS by a stand-in for the world."""

from __future__ import annotations

import math

import numpy as np
import pytest
from geometry_msgs.msg import TwistStamped
from rcl_interfaces.msg import Log
from rclpy.node import Node
from rclpy.parameter import Parameter
from sensor_msgs.msg import Image, LaserScan
from std_msgs.msg import Bool, String, UInt8

from mona_controller.contract import Announcement
from mona_controller.controllers import ControllerParams, controller_class
from mona_controller.controllers.beeclust import FOLLOW, WAIT
from mona_controller.mona import MonaParams
from mona_controller.ros import qos
from mona_controller.ros.controller_node import ControllerNode, parse_robots
from mona_controller.ros.messages import fill_readings, ground_image, proximity_scan, stamp_to_ns
from mona_controller.schema import ParameterError

pytestmark = pytest.mark.ros

ROBOT = 3
START_NS = 5_000_000_000  # the episode starts at 5 s of sim time
STEP_NS = 32_000_000
NOTHING = np.full(5, np.inf, dtype=np.float32)


class Driver(Node):
    """Plays the world for one robot: announces episodes, sends readings, records answers."""

    def __init__(self, robot: int, **kwargs) -> None:
        super().__init__('driver', **kwargs)
        self.robot = robot
        # (kind, value) in the order the controller published them (source timestamps)
        self.received: list[tuple[int, str, object]] = []
        self.episode_pub = self.create_publisher(String, qos.EPISODE, qos.EPISODE_QOS)
        self.ground_pub = self.create_publisher(Image, qos.robot_topic(robot, qos.GROUND),
                                                qos.SENSOR_QOS)
        self.scan_pub = self.create_publisher(LaserScan, qos.robot_topic(robot, qos.PROXIMITY),
                                              qos.SENSOR_QOS)
        self.cmd_sub = self.create_subscription(
            TwistStamped, qos.robot_topic(robot, qos.CMD_VEL), self._on_cmd, qos.COMMAND_QOS)
        self.create_subscription(Bool, qos.robot_topic(robot, qos.CLEANER), self._on_cleaner,
                                 qos.CLEANER_QOS)
        self.create_subscription(UInt8, qos.robot_topic(robot, qos.STATE), self._on_state,
                                 qos.STATE_QOS)
        self.warnings: list[str] = []  # the controller's warnings, from /rosout
        self.create_subscription(Log, '/rosout', self._on_log, 100)
        self.ground_msg = ground_image(robot)
        self.scan_msg = proximity_scan(robot, MonaParams())

    def _on_cmd(self, msg: TwistStamped, info) -> None:
        self.received.append((info['source_timestamp'], 'cmd', (
            stamp_to_ns(msg.header.stamp), msg.twist.linear.x, msg.twist.angular.z)))

    def _on_cleaner(self, msg: Bool, info) -> None:
        self.received.append((info['source_timestamp'], 'cleaner', msg.data))

    def _on_state(self, msg: UInt8, info) -> None:
        self.received.append((info['source_timestamp'], 'state', msg.data))

    def _on_log(self, msg: Log) -> None:
        if msg.name == f'mona_{self.robot}.mona_controller' and msg.level == Log.WARN:
            self.warnings.append(msg.msg)

    @property
    def answers(self) -> list[tuple[str, object]]:
        return [(kind, value) for _, kind, value in sorted(self.received, key=lambda r: r[0])]

    def connected(self) -> bool:
        return (self.ground_pub.get_subscription_count() > 0
                and self.scan_pub.get_subscription_count() > 0
                and self.cmd_sub.get_publisher_count() > 0)

    def announce(self, seed: int = 1, episode: int = 0, start_ns: int = START_NS) -> None:
        self.episode_pub.publish(String(data=Announcement(
            episode, seed=seed, population=self.robot + 1, duration=10.0, start_ns=start_ns,
            poses=((1.0, 1.0, 0.0),) * (self.robot + 1)).to_json()))

    def send(self, stamp_ns: int, ground=(0, 0), ranges=NOTHING, is_robot=None) -> None:
        is_robot = np.zeros(len(ranges), dtype=bool) if is_robot is None else is_robot
        fill_readings(self.ground_msg, self.scan_msg, np.asarray(ground, dtype=np.uint8),
                      np.asarray(ranges, dtype=np.float32), np.asarray(is_robot), stamp_ns)
        self.ground_pub.publish(self.ground_msg)
        self.scan_pub.publish(self.scan_msg)

    def answered(self, n: int) -> bool:
        """Both halves of ``n`` answers arrived."""
        kinds = [kind for _, kind, _ in self.received]
        return all(kinds.count(kind) >= n for kind in ('cmd', 'cleaner', 'state'))

    def commands(self) -> list[tuple[int, float, float]]:
        return [value for kind, value in self.answers if kind == 'cmd']


def test_a_renamed_key_still_works_and_the_kinds_sections_are_parameters(executor):
    """An old key (a file from before the kinds had sections) sets its new key, which the
    node declares as a ROS parameter, as it does every kind's section."""
    node = ControllerNode(ROBOT, context=executor.context,
                          parameter_overrides=[Parameter('controller.alpha', value=3.5)])
    try:
        assert node.params.beeclust.alpha == 3.5
        assert node.get_parameter('controller.beeclust.alpha').value == 3.5
        assert node.get_parameter('controller.network.hidden').value == 8
        assert node.get_parameter('controller.alpha').value == 3.5  # declared, deprecated
    finally:
        node.destroy_node()


@pytest.fixture
def pair(executor, spin_until):
    """A controller node for robot 3 and its driver, connected."""
    controller = ControllerNode(ROBOT, context=executor.context)
    driver = Driver(ROBOT, context=executor.context)
    executor.add_node(controller)
    executor.add_node(driver)
    spin_until(driver.connected, what='controller and driver connected')
    return controller, driver


def test_answers_each_reading_once_with_its_stamp_and_the_eq2_turn(pair, spin_until):
    controller, driver = pair
    driver.announce()
    spin_until(lambda: controller.episode is not None, what='announcement received')
    # Stronger cue under the left wheel: eq. 2 turns left (counter-clockwise, angular > 0).
    driver.send(START_NS + STEP_NS, ground=(200, 100))
    spin_until(lambda: driver.answered(1), what='first answer')
    # The same stamp again (the world repeats readings it fears lost) gets the same answer,
    # not a new one, whatever it carries.
    driver.send(START_NS + STEP_NS, ground=(0, 255))
    spin_until(lambda: driver.answered(2), what='repeated answer')
    # Stronger on the right: turn right.
    driver.send(START_NS + 2 * STEP_NS, ground=(100, 200))
    spin_until(lambda: driver.answered(3), what='third answer')

    (stamp1, v1, w1), repeated, (stamp2, v2, w2) = driver.commands()
    assert repeated == (stamp1, v1, w1)
    assert (stamp1, stamp2) == (START_NS + STEP_NS, START_NS + 2 * STEP_NS)
    assert w1 > 0 > w2 and v1 > 0 and v2 > 0
    # The exact eq. 2 numbers: wheels beta -/+ (l - r) / alpha, through wheels_to_twist.
    mona, params = MonaParams(), ControllerParams()
    beta = params.speed / mona.wheel_unit_speed
    alpha = params.beeclust.alpha
    left, right = beta - 100 / alpha, beta + 100 / alpha
    left, right = min(max(left, 0), mona.max_wheel_command), min(right, mona.max_wheel_command)
    assert v1 == pytest.approx((left + right) / 2 * mona.wheel_unit_speed)
    assert w1 == pytest.approx((right - left) * mona.wheel_unit_speed / mona.wheel_separation)
    # Every answer is a state, a cleaner, then its cmd_vel, nothing else.
    assert [kind for kind, _ in driver.answers] == ['state', 'cleaner', 'cmd'] * 3
    assert [v for kind, v in driver.answers if kind == 'state'] == [FOLLOW] * 3


def test_readings_before_the_announcement_are_answered_after_it(pair, spin_until):
    controller, driver = pair
    driver.send(START_NS, ground=(50, 50))
    for _ in range(20):
        driver.executor.spin_once(timeout_sec=0.02)
    assert driver.commands() == []  # no episode yet: time is not known
    driver.announce()
    spin_until(lambda: driver.answered(1), what='the early reading answered')
    assert driver.commands()[0][0] == START_NS


def test_meeting_a_robot_stops_and_cleans_and_a_new_episode_resets(pair, spin_until):
    controller, driver = pair
    driver.announce(seed=7)
    spin_until(lambda: controller.episode is not None, what='announcement')
    robot_ahead = np.full(5, np.inf, dtype=np.float32)
    robot_ahead[2] = 0.01
    driver.send(START_NS, ground=(200, 200), ranges=robot_ahead,
                is_robot=np.isfinite(robot_ahead))
    spin_until(lambda: driver.answered(1), what='answer')
    assert driver.answers[-3:] == [('state', WAIT), ('cleaner', True),
                                   ('cmd', (START_NS, 0.0, 0.0))]

    driver.announce(seed=8, episode=1, start_ns=START_NS + 10 * STEP_NS)
    spin_until(lambda: controller.episode.episode == 1, what='second announcement')
    driver.send(START_NS + 10 * STEP_NS, ground=(200, 200))
    spin_until(lambda: driver.answered(2), what='answer in episode 1')
    assert driver.answers[-3:-1] == [('state', FOLLOW), ('cleaner', False)]  # not waiting
    assert driver.commands()[1][1] > 0


def test_bad_sensor_values_give_finite_commands(pair, spin_until):
    controller, driver = pair
    driver.announce()
    spin_until(lambda: controller.episode is not None, what='announcement')
    weird = np.array([np.nan, -np.inf, -1.0, 1e30, np.inf], dtype=np.float32)
    driver.send(START_NS, ground=(255, 0), ranges=weird,
                is_robot=np.array([True, False, True, False, True]))
    spin_until(lambda: driver.answered(1), what='first answer')
    # A scan with the wrong number of beams: unusable, the robot is told to hold still.
    driver.scan_msg.ranges = [0.01, 0.02]
    driver.scan_msg.intensities = [0.0, 0.0]
    driver.scan_msg.header.stamp.nanosec += STEP_NS
    driver.ground_msg.header.stamp.nanosec += STEP_NS
    driver.ground_pub.publish(driver.ground_msg)
    driver.scan_pub.publish(driver.scan_msg)
    spin_until(lambda: driver.answered(2), what='two answers')
    first, second = driver.commands()
    assert all(math.isfinite(x) for x in first[1:] + second[1:])
    assert second[1:] == (0.0, 0.0)
    # The repaired scan still shows the robot in contact (-inf and -1 m became 0 m).
    assert driver.answers[:2] == [('state', WAIT), ('cleaner', True)]


def test_a_repeat_of_an_older_answered_stamp_gets_its_answer_again(pair, spin_until):
    controller, driver = pair
    driver.announce()
    spin_until(lambda: controller.episode is not None, what='announcement')
    driver.send(START_NS, ground=(200, 100))
    spin_until(lambda: driver.answered(1), what='first answer')
    driver.send(START_NS + STEP_NS, ground=(100, 200))
    spin_until(lambda: driver.answered(2), what='second answer')
    # The first readings again (a driver resending what it fears lost), with other values.
    driver.send(START_NS, ground=(0, 255))
    spin_until(lambda: driver.answered(3), timeout=5.0, what='the older stamp answered again')
    first, _, repeated = driver.commands()
    assert repeated == first


def test_a_ground_image_of_2_x_1_is_answered_with_a_stop(pair, spin_until):
    controller, driver = pair
    driver.announce()
    spin_until(lambda: controller.episode is not None, what='announcement')
    driver.ground_msg.height, driver.ground_msg.width, driver.ground_msg.step = 2, 1, 1
    driver.send(START_NS, ground=(200, 100))
    spin_until(lambda: driver.answered(1), what='answer')
    assert driver.answers == [('state', FOLLOW), ('cleaner', False),
                              ('cmd', (START_NS, 0.0, 0.0))]


def test_each_kind_of_bad_input_is_logged(pair, spin_until):
    controller, driver = pair
    driver.announce()
    spin_until(lambda: controller.episode is not None, what='announcement')
    driver.ground_msg.encoding = 'rgb8'
    driver.send(START_NS)
    spin_until(lambda: any('ground' in w for w in driver.warnings), what='bad ground logged')
    driver.ground_msg.encoding = 'mono8'
    driver.send(START_NS + STEP_NS, ranges=NOTHING[:2])
    # Within the 5 s of the ground warning: another kind of bad input is still logged.
    spin_until(lambda: any('proximity' in w for w in driver.warnings), timeout=3.0,
               what='bad proximity logged too')
    # The same kind again within 5 s is answered but not logged again.
    driver.send(START_NS + 2 * STEP_NS, ranges=NOTHING[:2])
    spin_until(lambda: driver.answered(3), what='three answers')
    for _ in range(10):
        driver.executor.spin_once(timeout_sec=0.02)
    assert len(driver.warnings) == 2, driver.warnings
    assert [value[1:] for value in driver.commands()] == [(0.0, 0.0)] * 3


def test_the_controller_is_the_kind_the_parameters_name(executor):
    node = ControllerNode(ROBOT, context=executor.context,
                          parameter_overrides=[Parameter('controller.kind', value='beeclust')])
    executor.add_node(node)
    assert node.params.kind == 'beeclust'
    assert type(node.controller) is controller_class('beeclust')
    assert node.controller.robot_ids.tolist() == [ROBOT]
    with pytest.raises(ParameterError, match="controller.kind = 'neural' is not allowed"):
        ControllerNode(ROBOT + 1, context=executor.context,
                       parameter_overrides=[Parameter('controller.kind', value='neural')])


def test_robot_ids_and_their_namespace():
    assert parse_robots('0-3,7') == [0, 1, 2, 3, 7]
    with pytest.raises(ParameterError, match='--robots'):
        parse_robots('3-x')
    with pytest.raises(ParameterError, match='distinct'):
        parse_robots('1,1')
