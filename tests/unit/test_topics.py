"""The topic contract is one table (mona_controller.topics.TOPICS): every ROS-free consumer's
view of the topics (the bags' topic list and offered QoS, the live view's channels, the video's
reader) is that table, and docs/interfaces.md lists every topic with the table's type and QoS.
The rclpy side (profiles, node subscriptions) is checked in tests/bags/test_topic_views.py."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

from mona_controller import contract, topics
from mona_controller.topics import TOPICS
from swarm_metrics.bags.writer import offered_qos
from swarm_metrics.metrics import metric_names
from swarm_supervisor.media import live, recorded
from swarm_supervisor.outputs import bag

ROOT = Path(__file__).parents[2]
INTERFACES = ROOT / 'docs' / 'interfaces.md'


def test_each_entry_is_well_formed():
    for name, topic in TOPICS.items():
        assert name == topic.name
        assert re.fullmatch(r'[a-z_]+_msgs/msg/[A-Za-z0-9]+', topic.type), topic.type
        assert topic.qos.depth >= 1 and topic.doc
        assert topic.publisher in (topics.WORLD, topics.CONTROLLER, topics.SUPERVISOR,
                                   topics.METRICS)
        assert not (topic.per_robot and topic.recorded)  # per-robot topics: record_all only
    assert [t.name for t in TOPICS.values() if t.per_metric] == [topics.METRICS_PREFIX]


def test_names_resolve_to_their_entry():
    assert topics.topic_of('/mona_12/cmd_vel') is TOPICS[topics.CMD_VEL]
    assert topics.topic_of('/metrics/coherency') is TOPICS[topics.METRICS_PREFIX]
    assert topics.topic_of(topics.POSES) is TOPICS[topics.POSES]
    for outside in ('cmd_vel', '/metrics/', '/mona_x/ground', '/mona_1/poses', '/elsewhere'):
        assert topics.topic_of(outside) is None, outside


def test_the_embedded_bag_records_the_tables_recorded_topics():
    expected = {name: (topic.type, offered_qos(topic.qos.depth, reliable=topic.qos.reliable,
                                               latched=topic.qos.latched))
                for name, topic in topics.expand(topics.recorded(), metric_names()).items()}
    assert bag.TOPICS == expected
    assert {f'/metrics/{name}' for name in metric_names()} <= set(bag.TOPICS)
    assert topics.ROBOT_STATES in bag.TOPICS and topics.RECORDERS not in bag.TOPICS
    # The offered QoS is the table's numbers, e.g. the poses' deep history.
    assert bag.TOPICS[topics.POSES][1].depth == 1000
    assert bag.TOPICS[topics.CLOCK][1] == offered_qos(1, reliable=False)


def test_the_live_view_carries_the_tables_live_topics():
    assert live.LIVE_TOPICS == {name: topic.type for name, topic in
                                topics.expand(topics.live(), metric_names()).items()}
    # The cleaning events are shown by the cue map; the grid and markers are live only.
    assert topics.CLEANING not in live.LIVE_TOPICS
    assert {topics.CUE_GRID, topics.MARKERS} <= set(live.LIVE_TOPICS) - set(bag.TOPICS)


def test_no_consumer_names_a_topic_the_table_does_not_have():
    """Every topic constant the consumers use is an entry (the video reads the bag's robot
    states by the contract's name, not a copy)."""
    assert recorded.ROBOT_STATES is topics.ROBOT_STATES
    for module in (bag, live, recorded):
        tree = ast.parse(Path(module.__file__).read_text())
        literals = {node.value for node in ast.walk(tree) if isinstance(node, ast.Constant)
                    and isinstance(node.value, str) and re.fullmatch(r'/[a-z_/]+', node.value)}
        assert not literals, (module.__name__, literals)


def _doc_rows() -> dict[str, tuple[str, str]]:
    """topic -> (type, QoS text) of every table row of docs/interfaces.md."""
    rows = {}
    for line in INTERFACES.read_text().splitlines():
        cells = [cell.strip() for cell in line.strip().strip('|').split('|')]
        if len(cells) >= 3 and cells[0].startswith('`') and cells[1].startswith('`'):
            rows[cells[0].strip('`')] = (cells[1].split(' ')[0].strip('`'),
                                         ' '.join(cells[2:4]))
    return rows


@pytest.mark.parametrize('name', list(TOPICS))
def test_interfaces_md_lists_every_topic_with_its_type_and_depth(name):
    topic = TOPICS[name]
    rows = _doc_rows()
    # The per-metric entry is documented one row per metric.
    doc_name = f'{name}{metric_names()[0]}' if topic.per_metric else name
    assert doc_name in rows, f'docs/interfaces.md has no row for {doc_name}'
    doc_type, doc_qos = rows[doc_name]
    assert topic.type.replace('/msg/', '/') == doc_type
    if topic.per_metric:
        return  # the metrics table states its QoS once, below the rows
    assert re.search(rf'keep last {topic.qos.depth}\b', doc_qos), doc_qos
    assert ('best effort' in doc_qos) == (not topic.qos.reliable)
    assert ('transient local' in doc_qos) == topic.qos.latched


def test_the_contract_imports_nothing_of_ros():
    for module in (topics, contract):
        tree = ast.parse(Path(module.__file__).read_text())
        imported = {alias.name.split('.')[0] for node in ast.walk(tree)
                    if isinstance(node, ast.Import) for alias in node.names}
        imported |= {node.module.split('.')[0] for node in ast.walk(tree)
                     if isinstance(node, ast.ImportFrom) and node.module}
        assert not imported & {'rclpy', 'rosbags', 'std_msgs'}, module.__name__
