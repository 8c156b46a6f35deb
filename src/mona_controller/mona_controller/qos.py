"""The topic contract in code: topic names and their named QoS profiles (docs/interfaces.md).

Every node takes its names and QoS from here, so publisher and subscriber always match. Per
robot topics are relative names, resolved in the robot's namespace ``/mona_<i>``.
"""

from __future__ import annotations

from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy


def _profile(depth: int, *, reliable: bool = True, latched: bool = False) -> QoSProfile:
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST, depth=depth,
        reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE)


#: ground, proximity and cmd_vel: every reading and every answer must arrive (lockstep).
SENSOR_QOS = _profile(5)
COMMAND_QOS = _profile(5)
#: The cleaning actuator is a state: a late joiner gets the latest one.
CLEANER_QOS = _profile(1, latched=True)
#: /clock as the ROS clock QoS (rclpy's time source subscribes best effort, depth 1).
CLOCK_QOS = _profile(1, reliable=False)
#: Poses and cleaning events feed the metrics, which must see every one: a deep history lets
#: a metrics node that falls behind on a loaded machine catch up (about 30 s of steps)
#: instead of losing the pose of a sample time.
POSES_QOS = _profile(1000)
CLEANING_QOS = _profile(1000)
#: The cue map, its grid, /world/status and /episode: the latest value, kept for late joiners.
LATCHED_QOS = _profile(1, latched=True)
MAP_QOS = LATCHED_QOS
STATUS_QOS = LATCHED_QOS
EPISODE_QOS = LATCHED_QOS
MARKERS_QOS = _profile(1)

#: No default QoS event handlers for the per-robot topics. rclpy gives every publisher and
#: subscription two (incompatible QoS, incompatible type) and the executor visits each of
#: them in Python at every wait: for the world node's 4 N endpoints that dominated a lockstep
#: round. The QoS is fixed here for both ends, and the world reports robots that never connect.
QUIET_PUBLISHER = PublisherEventCallbacks(use_default_callbacks=False)
QUIET_SUBSCRIPTION = SubscriptionEventCallbacks(use_default_callbacks=False)

# Per robot, relative to the namespace /mona_<i>.
GROUND = 'ground'
PROXIMITY = 'proximity'
CMD_VEL = 'cmd_vel'
CLEANER = 'cleaner'

# World and supervisor (absolute).
CLOCK = '/clock'
POSES = '/world/poses'
CLEANING = '/world/cleaning'
CUE_MAP = '/world/cue_map'
CUE_GRID = '/world/cue_grid'
MARKERS = '/world/markers'
STATUS = '/world/status'
EPISODE = '/episode'

#: The world frame (REP 103: origin at an arena corner, x and y along the walls).
WORLD_FRAME = 'world'


def robot_namespace(robot_id: int) -> str:
    """The namespace of robot ``robot_id`` (ROS names must not start with a digit)."""
    return f'/mona_{robot_id}'


def robot_topic(robot_id: int, name: str) -> str:
    """The absolute name of a per-robot topic, e.g. ``/mona_3/cmd_vel``."""
    return f'{robot_namespace(robot_id)}/{name}'


def base_frame(robot_id: int) -> str:
    """The body frame of robot ``robot_id``."""
    return f'mona_{robot_id}/base_link'
