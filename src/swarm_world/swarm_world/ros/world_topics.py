"""The world's own topics (docs/interfaces.md, "World"): its publishers, and the messages it
fills for them from the world's state (:mod:`swarm_world.ros.world_messages`)."""

from __future__ import annotations

import numpy as np
from geometry_msgs.msg import PoseArray
from nav_msgs.msg import OccupancyGrid
from rclpy.node import Node
from rosgraph_msgs.msg import Clock as ClockMsg
from sensor_msgs.msg import Image
from std_msgs.msg import String, UInt8MultiArray
from visualization_msgs.msg import MarkerArray

from mona_controller.contract import WorldStatus
from mona_controller.ros import qos
from mona_controller.ros.messages import set_stamp
from swarm_world.arena import Arena
from swarm_world.ros.world_messages import (
    PoseArrayFiller,
    cue_grid,
    cue_image,
    obstacle_markers,
    robot_markers,
    robot_states,
    source_markers,
)
from swarm_world.world import World


class WorldTopics:
    """The publishers of the world's topics, made on ``node``; the obstacles of ``arena`` go
    out at once, latched: the arena is the node's for its lifetime (an announcement with
    other world parameters is rejected), so once is enough for every episode."""

    def __init__(self, node: Node, arena: Arena) -> None:
        self.clock_pub = node.create_publisher(ClockMsg, qos.CLOCK, qos.CLOCK_QOS)
        self.poses_pub = node.create_publisher(PoseArray, qos.POSES, qos.POSES_QOS)
        self.cleaning_pub = node.create_publisher(PoseArray, qos.CLEANING, qos.CLEANING_QOS)
        self.map_pub = node.create_publisher(Image, qos.CUE_MAP, qos.MAP_QOS)
        self.grid_pub = node.create_publisher(OccupancyGrid, qos.CUE_GRID, qos.MAP_QOS)
        self.markers_pub = node.create_publisher(MarkerArray, qos.MARKERS, qos.MARKERS_QOS)
        self.states_pub = node.create_publisher(UInt8MultiArray, qos.ROBOT_STATES,
                                                qos.ROBOT_STATES_QOS)
        self.sources_pub = node.create_publisher(MarkerArray, qos.SOURCES, qos.SOURCES_QOS)
        self.obstacles_pub = node.create_publisher(MarkerArray, qos.OBSTACLES,
                                                   qos.OBSTACLES_QOS)
        self.obstacles_pub.publish(obstacle_markers(arena))
        self.status_pub = node.create_publisher(String, qos.STATUS, qos.STATUS_QOS)
        self.poses_filler = PoseArrayFiller()
        self.cleaning_filler = PoseArrayFiller()
        self.clock_msg = ClockMsg()

    def recording_subscriptions(self) -> int:
        """How many subscribers the poses, states and cleaning events (volatile: no history
        for late joiners) each have at least."""
        return min(self.poses_pub.get_subscription_count(),
                   self.cleaning_pub.get_subscription_count(),
                   self.states_pub.get_subscription_count())

    def clock(self, time_ns: int) -> None:
        """/clock at sim time ``time_ns``."""
        set_stamp(self.clock_msg.clock, time_ns)
        self.clock_pub.publish(self.clock_msg)

    def poses(self, poses: np.ndarray, states: np.ndarray, time_ns: int) -> None:
        """The robots' states, then their poses: the n-th /world/robot_states goes with the
        n-th /world/poses of the episode (the states array carries no stamp)."""
        self.states_pub.publish(robot_states(states))
        self.poses_pub.publish(self.poses_filler.fill(poses, time_ns))

    def cleaning(self, poses: np.ndarray, time_ns: int) -> None:
        """A cleaning event: the poses of the robots that cleaned at ``time_ns``."""
        self.cleaning_pub.publish(self.cleaning_filler.fill(poses, time_ns))

    def map(self, world: World, cell_size: float, states: np.ndarray, body_radius: float,
            palette: tuple[tuple[float, ...], ...], time_ns: int) -> None:
        """The cue map, its occupancy grid, the sources and the robot markers."""
        self.map_pub.publish(cue_image(world.cue, time_ns))
        field = world.field
        self.sources_pub.publish(source_markers(
            field.names, field.source_positions(world.time_ns / 1e9), time_ns))
        self.grid_pub.publish(cue_grid(world.cue, cell_size, time_ns))
        self.markers_pub.publish(robot_markers(world.poses, states, body_radius, time_ns,
                                               palette=palette))

    def status(self, status: WorldStatus) -> None:
        """/world/status."""
        self.status_pub.publish(String(data=status.to_json()))
