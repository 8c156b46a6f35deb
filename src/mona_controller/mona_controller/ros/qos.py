"""The topic contract's QoS as rclpy profiles, built from the table (docs/interfaces.md).

Every node takes its names and QoS from here, so publisher and subscriber always match. The
numbers live in :data:`mona_controller.topics.TOPICS`; this module only turns them into
:class:`QoSProfile` objects (the named constants below are those profiles, kept so node code
reads ``qos.POSES_QOS``). Per robot topics are relative names, resolved in the robot's
namespace ``/mona_<i>``.
"""

from __future__ import annotations

import importlib

from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from mona_controller.contract import WORLD_FRAME, base_frame  # noqa: F401

# The topic table's names, re-exported so a node needs one import for name and QoS.
from mona_controller.topics import (  # noqa: F401
    CLEANER,
    CLEANING,
    CLOCK,
    CMD_VEL,
    CUE_GRID,
    CUE_MAP,
    EPISODE,
    GROUND,
    MARKERS,
    METRICS_PREFIX,
    OBSTACLES,
    POSES,
    PROXIMITY,
    RECORDERS,
    ROBOT_STATES,
    SOURCES,
    STATE,
    STATUS,
    TOPICS,
    QoS,
    metric_topic,
    robot_namespace,
    robot_topic,
    topic_of,
)


def profile(qos: QoS) -> QoSProfile:
    """The rclpy profile of a contract QoS."""
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST, depth=qos.depth,
        reliability=ReliabilityPolicy.RELIABLE if qos.reliable else ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if qos.latched else DurabilityPolicy.VOLATILE)


#: Every entry's profile, by the table's name (relative per robot, '/metrics/' per metric).
PROFILES: dict[str, QoSProfile] = {name: profile(topic.qos) for name, topic in TOPICS.items()}


def profile_for(name: str) -> QoSProfile | None:
    """The profile of an absolute topic name (``/mona_3/ground``, ``/metrics/coherency``), or
    None for a topic outside the contract."""
    topic = topic_of(name)
    return None if topic is None else PROFILES[topic.name]


def message_class(type_name: str) -> type:
    """The rclpy message class of a type name such as 'std_msgs/msg/String'.

    Raises:
        ImportError: the package is not installed.
        AttributeError: it has no such message.
        ValueError: not a 'package/msg/Name'.
    """
    package, kind, name = type_name.split('/')
    return getattr(importlib.import_module(f'{package}.{kind}'), name)


SENSOR_QOS = PROFILES[GROUND]  #: ground and proximity
COMMAND_QOS = PROFILES[CMD_VEL]
CLEANER_QOS = PROFILES[CLEANER]
STATE_QOS = PROFILES[STATE]
CLOCK_QOS = PROFILES[CLOCK]
POSES_QOS = PROFILES[POSES]
CLEANING_QOS = PROFILES[CLEANING]
MAP_QOS = PROFILES[CUE_MAP]  #: the cue map and its grid
STATUS_QOS = PROFILES[STATUS]
EPISODE_QOS = PROFILES[EPISODE]
MARKERS_QOS = PROFILES[MARKERS]
OBSTACLES_QOS = PROFILES[OBSTACLES]
ROBOT_STATES_QOS = PROFILES[ROBOT_STATES]
SOURCES_QOS = PROFILES[SOURCES]
RECORDERS_QOS = PROFILES[RECORDERS]
METRICS_QOS = PROFILES[METRICS_PREFIX]  #: every /metrics/<name>

#: No default QoS event handlers for the per-robot topics. rclpy gives every publisher and
#: subscription two (incompatible QoS, incompatible type) and the executor visits each of
#: them in Python at every wait: for the world node's 4 N endpoints that dominated a lockstep
#: round. The QoS is fixed here for both ends, and the world reports robots that never connect.
QUIET_PUBLISHER = PublisherEventCallbacks(use_default_callbacks=False)
QUIET_SUBSCRIPTION = SubscriptionEventCallbacks(use_default_callbacks=False)
