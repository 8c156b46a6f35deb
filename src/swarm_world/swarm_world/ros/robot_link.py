"""The world's end of one robot's topics (docs/interfaces.md, "Per robot"): its readings
out, its state, cleaner and commands in, with the messages built once and reused."""

from __future__ import annotations

from functools import partial

import numpy as np
from geometry_msgs.msg import TwistStamped
from rclpy.node import Node
from sensor_msgs.msg import Image, LaserScan
from std_msgs.msg import Bool, UInt8

from mona_controller.mona import MonaParams
from mona_controller.ros import qos
from mona_controller.ros.messages import fill_readings, ground_image, proximity_scan


class RobotLink:
    """The world's end of one robot's topics, with messages built once and reused."""

    def __init__(self, node: Node, robot_id: int, mona: MonaParams, on_state, on_cleaner,
                 on_cmd):
        self.robot_id = robot_id
        self.ground_msg = ground_image(robot_id)
        self.scan_msg = proximity_scan(robot_id, mona)
        quiet_pub, quiet_sub = qos.QUIET_PUBLISHER, qos.QUIET_SUBSCRIPTION
        self.ground_pub = node.create_publisher(Image, qos.robot_topic(robot_id, qos.GROUND),
                                                qos.SENSOR_QOS, event_callbacks=quiet_pub)
        self.scan_pub = node.create_publisher(LaserScan,
                                              qos.robot_topic(robot_id, qos.PROXIMITY),
                                              qos.SENSOR_QOS, event_callbacks=quiet_pub)
        # state and cleaner before cmd_vel: the executor (ros/spinning.py) handles them in the
        # order they arrive, which is the order the controller publishes them in.
        self.state_sub = node.create_subscription(
            UInt8, qos.robot_topic(robot_id, qos.STATE), partial(on_state, robot_id),
            qos.STATE_QOS, event_callbacks=quiet_sub)
        self.cleaner_sub = node.create_subscription(
            Bool, qos.robot_topic(robot_id, qos.CLEANER), partial(on_cleaner, robot_id),
            qos.CLEANER_QOS, event_callbacks=quiet_sub)
        self.cmd_sub = node.create_subscription(
            TwistStamped, qos.robot_topic(robot_id, qos.CMD_VEL), partial(on_cmd, robot_id),
            qos.COMMAND_QOS, event_callbacks=quiet_sub)

    def connected(self) -> bool:
        """A controller listens to both readings and publishes commands."""
        return (self.ground_pub.get_subscription_count() > 0
                and self.scan_pub.get_subscription_count() > 0
                and self.cmd_sub.get_publisher_count() > 0)

    def publish(self, ground: np.ndarray, ranges: np.ndarray, is_robot: np.ndarray,
                stamp_ns: int) -> None:
        """Publish one robot's readings for the step stamped ``stamp_ns``."""
        fill_readings(self.ground_msg, self.scan_msg, ground, ranges, is_robot, stamp_ns)
        self.resend()

    def resend(self) -> None:
        """Publish the current readings (again)."""
        self.ground_pub.publish(self.ground_msg)
        self.scan_pub.publish(self.scan_msg)

    def take_waiting(self) -> None:
        """Handle the cleaner and command messages that wait in the subscriptions now, as the
        executor would (state and cleaner first)."""
        for subscription in (self.state_sub, self.cleaner_sub, self.cmd_sub):
            while True:
                with subscription.handle:
                    taken = subscription.handle.take_message(subscription.msg_type,
                                                             subscription.raw)
                if taken is None:
                    break
                subscription.callback(taken[0])
