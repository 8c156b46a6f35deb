"""The topic contract's QoS: a named profile per topic (docs/interfaces.md).

Every node takes its names and QoS from here, so publisher and subscriber always match. Per
robot topics are relative names, resolved in the robot's namespace ``/mona_<i>``.
"""

from __future__ import annotations

from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

# The names are the contract's; re-exported so a node needs one import for name and QoS.
from mona_controller.contract import (CLEANER, CLEANING, CLOCK, CMD_VEL, CUE_GRID,  # noqa: F401
                                      CUE_MAP, EPISODE, GROUND, MARKERS, POSES, PROXIMITY,
                                      RECORDERS, STATUS, WORLD_FRAME, base_frame,
                                      robot_namespace, robot_topic)


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
#: Recorder reports: each recorder's latest kept for late joiners; several recorders (and a
#: burst of progress reports) must not push a "recording" out of a subscriber's history.
RECORDERS_QOS = _profile(10, latched=True)

#: No default QoS event handlers for the per-robot topics. rclpy gives every publisher and
#: subscription two (incompatible QoS, incompatible type) and the executor visits each of
#: them in Python at every wait: for the world node's 4 N endpoints that dominated a lockstep
#: round. The QoS is fixed here for both ends, and the world reports robots that never connect.
QUIET_PUBLISHER = PublisherEventCallbacks(use_default_callbacks=False)
QUIET_SUBSCRIPTION = SubscriptionEventCallbacks(use_default_callbacks=False)
