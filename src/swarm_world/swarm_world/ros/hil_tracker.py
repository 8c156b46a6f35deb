"""The hardware-in-the-loop harness's ROS side: a simulated overhead tracker that publishes
the emulated robots' poses, and the operator who places the robots at each announced episode's
poses (docs/driver.md, "Hardware in the loop")."""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np
import rclpy
from geometry_msgs.msg import PoseArray
from rclpy.executors import SingleThreadedExecutor
from std_msgs.msg import String

from mona_controller.contract import Announcement, ContractError
from mona_controller.ros import qos
from swarm_world.ros.driver_node import TRACKER_QOS
from swarm_world.ros.world_messages import PoseArrayFiller


class Tracker:
    """Publishes tracked poses (frame ``world``, stamped with the capture time) on ``topic``;
    calls ``place(poses)`` for each new episode announcement."""

    def __init__(self, topic: str, place: Callable[[np.ndarray], None]) -> None:
        self.context = rclpy.Context()
        rclpy.init(args=[], context=self.context)
        self.node = rclpy.create_node('hil_tracker', context=self.context)
        self.publisher = self.node.create_publisher(PoseArray, topic, TRACKER_QOS)
        self.node.create_subscription(String, qos.EPISODE, self.on_episode, qos.EPISODE_QOS)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.filler = PoseArrayFiller()
        self.place = place
        self.key: object = None

    def on_episode(self, msg: String) -> None:
        """Place the robots at a new episode's announced poses."""
        try:
            announcement = Announcement.from_json(msg.data)
        except ContractError:
            return
        if announcement.shutdown or announcement.key == self.key:
            return
        self.key = announcement.key
        self.place(np.array(announcement.poses, dtype=np.float64).reshape(-1, 3))

    def publish(self, capture: tuple[int, np.ndarray]) -> None:
        """Publish poses captured at wall time ``capture[0]`` (ns)."""
        stamp_ns, poses = capture
        self.publisher.publish(self.filler.fill(poses, stamp_ns))

    def spin(self, timeout: float) -> None:
        """Handle what arrived, waiting at most ``timeout`` s."""
        self.executor.spin_once(timeout_sec=max(0.0, timeout))

    def close(self) -> None:
        """Leave ROS."""
        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)


def capture(poses: np.ndarray) -> tuple[int, np.ndarray]:
    """Poses with their capture stamp (wall time, ns)."""
    return time.time_ns(), poses
