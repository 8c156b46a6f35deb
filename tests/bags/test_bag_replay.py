"""``mona-swarm replay``: a bag played back onto its topics, byte for byte, with /clock."""

from __future__ import annotations

import time

import pytest
import rclpy
from geometry_msgs.msg import PoseArray
from rosgraph_msgs.msg import Clock
from std_msgs.msg import Float64

from mona_controller.ros import qos
from swarm_metrics.bags.scan import McapScan
from swarm_supervisor.config import load_config

from bagtools import embedded_episode_bag

pytestmark = pytest.mark.ros


def test_replay_publishes_the_recorded_bytes(processes, tmp_path):
    config = load_config().replace(episode={'population': 4, 'duration': 6.0, 'seed': 3})
    embedded_episode_bag(tmp_path / 'bag', config)
    recorded = {m.topic: [] for m in McapScan(tmp_path / 'bag' / 'bag.mcap')}
    for message in McapScan(tmp_path / 'bag' / 'bag.mcap'):
        recorded[message.topic].append(message.data)

    rclpy.init()
    node = rclpy.create_node('listener')
    received = {qos.POSES: [], '/metrics/coherency': [], qos.CLOCK: []}
    try:
        for topic, kind, profile in ((qos.POSES, PoseArray, qos.POSES_QOS),
                                     ('/metrics/coherency', Float64, 10),
                                     (qos.CLOCK, Clock, qos.CLOCK_QOS)):
            node.create_subscription(kind, topic, received[topic].append, profile, raw=True)
        # 6 s of sim time at 10x, after 3 s for discovery
        replay = processes.spawn(['mona-swarm', 'replay', str(tmp_path / 'bag'), '--pace',
                                  '10', '--delay', '3'], 'replay')
        deadline = time.monotonic() + 90
        while replay.poll() is None and time.monotonic() < deadline:
            rclpy.spin_once(node, timeout_sec=0.05)
        for _ in range(20):  # what is still in flight
            rclpy.spin_once(node, timeout_sec=0.05)
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    assert replay.returncode == 0, processes.log('replay')
    assert 'replayed' in processes.log('replay')
    assert received[qos.POSES] == recorded[qos.POSES]  # the same bytes, in order
    assert received['/metrics/coherency'] == recorded['/metrics/coherency']
    assert len(received[qos.CLOCK]) >= 5  # synthesized from the log times (none recorded)
