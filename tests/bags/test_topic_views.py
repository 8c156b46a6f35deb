"""The rclpy side of the topic table: each QoS profile has the table's numbers, and the nodes
built from the table (the metrics node, the live node, replay) subscribe and publish exactly
the table's topics with its types and profiles. Real nodes in this process, in the test's
private domain."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
import rclpy
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, HistoryPolicy, ReliabilityPolicy

from mona_controller import topics
from mona_controller.ros import qos
from mona_controller.topics import TOPICS
from swarm_metrics.metrics import metric_names
from swarm_metrics.ros.metrics_node import RECORDED, RECORDED_ALL, MetricsNode
from swarm_supervisor.system.ros.live_node import NODE_TOPICS, LiveNode

pytestmark = pytest.mark.ros


def type_name(msg_class: type) -> str:
    return f'{msg_class.__module__.split(".")[0]}/msg/{msg_class.__name__}'


@pytest.fixture
def context(ros_env: dict[str, str]) -> Iterator[rclpy.Context]:
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=int(ros_env['ROS_DOMAIN_ID']))
    try:
        yield context
    finally:
        rclpy.try_shutdown(context=context)


@pytest.mark.parametrize('name', list(TOPICS))
def test_each_profile_has_the_tables_numbers(name):
    entry, profile = TOPICS[name], qos.PROFILES[name]
    assert profile.history == HistoryPolicy.KEEP_LAST
    assert profile.depth == entry.qos.depth
    assert (profile.reliability == ReliabilityPolicy.RELIABLE) == entry.qos.reliable
    assert profile.reliability in (ReliabilityPolicy.RELIABLE, ReliabilityPolicy.BEST_EFFORT)
    assert (profile.durability == DurabilityPolicy.TRANSIENT_LOCAL) == entry.qos.latched
    assert profile.durability in (DurabilityPolicy.TRANSIENT_LOCAL, DurabilityPolicy.VOLATILE)
    assert type_name(qos.message_class(entry.type)) == entry.type


def test_the_named_profiles_are_the_tables():
    named = [(qos.SENSOR_QOS, (topics.GROUND, topics.PROXIMITY)),
             (qos.COMMAND_QOS, (topics.CMD_VEL,)), (qos.CLEANER_QOS, (topics.CLEANER,)),
             (qos.CLOCK_QOS, (topics.CLOCK,)), (qos.POSES_QOS, (topics.POSES,)),
             (qos.CLEANING_QOS, (topics.CLEANING,)),
             (qos.MAP_QOS, (topics.CUE_MAP, topics.CUE_GRID)),
             (qos.STATUS_QOS, (topics.STATUS,)), (qos.EPISODE_QOS, (topics.EPISODE,)),
             (qos.MARKERS_QOS, (topics.MARKERS,)), (qos.OBSTACLES_QOS, (topics.OBSTACLES,)),
             (qos.RECORDERS_QOS, (topics.RECORDERS,)),
             (qos.METRICS_QOS, (topics.METRICS_PREFIX,))]
    for profile, names in named:
        for name in names:
            assert profile == qos.PROFILES[name], name
    # What replay offers a recorded topic: its entry's profile, per robot and per metric too.
    assert qos.profile_for('/mona_7/ground') == qos.SENSOR_QOS
    assert qos.profile_for('/metrics/coherency') == qos.METRICS_QOS
    assert qos.profile_for('/not/in/the/contract') is None


def endpoints(endpoints_of_node, *, skip: tuple[str, ...] = ()) -> dict[str, tuple]:
    """topic -> (type name, profile) of a node's endpoints that belong to the contract."""
    return {e.topic_name: (type_name(e.msg_type), e.qos_profile) for e in endpoints_of_node
            if topics.topic_of(e.topic_name) is not None and e.topic_name not in skip}


def as_table(names) -> dict[str, tuple]:
    return {name: (topics.topic_of(name).type, qos.profile_for(name)) for name in names}


def test_the_metrics_node_subscribes_to_the_tables_recorded_topics(context, tmp_path: Path):
    overrides = [Parameter('output_dir', value=str(tmp_path)),
                 Parameter('record_all', value=True)]
    node = MetricsNode(context=context, parameter_overrides=overrides)
    try:
        assert set(node.handlers) == set(RECORDED) | set(RECORDED_ALL)
        # The recorded topics that another node publishes: all but its own.
        assert set(RECORDED) == {name for name, t in topics.recorded().items()
                                 if t.publisher != topics.METRICS}
        world_wide = [n for n in RECORDED_ALL if not TOPICS[n].per_robot]
        assert endpoints(node.subscriptions) == as_table([*RECORDED, *world_wide])
        node._subscribe_robots(2)  # what an announcement of N = 2 does with record_all
        per_robot = [topics.robot_topic(i, n) for i in range(2) for n in RECORDED_ALL
                     if TOPICS[n].per_robot]
        assert endpoints(node.subscriptions) == as_table([*RECORDED, *world_wide, *per_robot])
        assert endpoints(node.publishers) == as_table(
            [topics.RECORDERS, *(topics.metric_topic(name) for name in metric_names())])
    finally:
        node.destroy_node()


def test_the_live_node_forwards_the_tables_live_topics(context):
    node = LiveNode(context=context, parameter_overrides=[Parameter('port', value=0)])
    try:
        assert set(node.server.channels) == set(NODE_TOPICS)
        assert endpoints(node.subscriptions) == as_table(NODE_TOPICS)
        assert {topics.ROBOT_STATES, topics.SOURCES} <= set(NODE_TOPICS)  # from the world
    finally:
        node.server.stop()
        node.destroy_node()
