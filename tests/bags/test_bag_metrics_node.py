"""The metrics node as a real process, fed by an in-process publisher with a world's messages.

Its online metrics must equal the embedded runner's and the offline recomputation from its
bag; the bag must be closed on a signal and when the world goes silent.
"""

from __future__ import annotations

import json
import signal
import time
from pathlib import Path

import numpy as np
import pytest
import rclpy
from geometry_msgs.msg import PoseArray, TwistStamped
from sensor_msgs.msg import Image
from std_msgs.msg import Bool, Float64, String

from mona_controller.ros import qos
from mona_controller.ros.messages import fill_twist, ground_image
from swarm_metrics.bags.analysis import recompute
from swarm_metrics.bags.reader import find_mcap, read_episode_bag
from swarm_supervisor.config import load_config
from swarm_supervisor.engine.episode import Episode
from swarm_supervisor.engine.runner import run_episode
from swarm_world.ros.world_messages import PoseArrayFiller, cue_image
from swarm_world.timing import crossed

from bagtools import announcement

pytestmark = pytest.mark.ros
START_NS = 3_000_000_000


class FakeWorld:
    """Publishes what the world node and the supervisor publish, from the embedded engine."""

    def __init__(self) -> None:
        self.node = rclpy.create_node('fake_world')
        self.episode = self.node.create_publisher(String, qos.EPISODE, qos.EPISODE_QOS)
        self.status = self.node.create_publisher(String, qos.STATUS, qos.STATUS_QOS)
        self.poses = self.node.create_publisher(PoseArray, qos.POSES, qos.POSES_QOS)
        self.cleaning = self.node.create_publisher(PoseArray, qos.CLEANING, qos.CLEANING_QOS)
        self.map = self.node.create_publisher(Image, qos.CUE_MAP, qos.MAP_QOS)
        self.filler = PoseArrayFiller()
        self.samples: list[float] = []
        self.node.create_subscription(Float64, '/metrics/mean_cue',
                                      lambda msg: self.samples.append(msg.data), 10)
        self.cleaned = PoseArrayFiller()

    def wait_for_metrics_node(self, timeout: float = 60.0) -> None:
        deadline = time.monotonic() + timeout
        publishers = (self.episode, self.status, self.poses, self.cleaning, self.map)
        while any(p.get_subscription_count() == 0 for p in publishers) \
                or self.node.count_publishers('/metrics/mean_cue') == 0:
            assert time.monotonic() < deadline, 'the metrics node never subscribed'
            time.sleep(0.1)

    def say(self, publisher, document: dict) -> None:
        publisher.publish(String(data=json.dumps(document)))

    def run(self, config, *, steps: int | None = None) -> None:
        """Announce and step one episode (the world node's order: cleaning, then poses).

        Poses go out at the steps the metrics node samples and the step after (which
        completes the sample); each sample is awaited on /metrics/mean_cue, so a slow
        machine cannot make the node's queues overflow.
        """
        episode = Episode(config)
        world = episode.world
        self.say(self.episode, announcement(config, world.poses, START_NS))
        self.say(self.status, {'episode': 0, 'state': 'running', 'time_ns': START_NS})
        self.wait_for_samples(1)
        map_ns, completes = 2_000_000_000, 0
        for _ in range(episode.steps_total if steps is None else steps):
            step = episode.step()
            now = START_NS + step.time_ns
            if len(step.cleaned):
                self.cleaning.publish(self.cleaned.fill(world.poses[step.cleaned], now))
            if crossed(step.before_ns, step.time_ns, map_ns):
                self.map.publish(cue_image(world.cue, now))
            if step.sampled or completes:
                self.poses.publish(self.filler.fill(world.poses, now))
            if completes:
                self.wait_for_samples(completes)
            completes = step.time_ns // episode.sample_ns + 1 if step.sampled else 0
        if steps is None:
            self.say(self.status, {'episode': 0, 'state': 'finished',
                                   'time_ns': START_NS + world.time_ns})

    def wait_for_samples(self, count: int, timeout: float = 60.0) -> None:
        deadline = time.monotonic() + timeout
        while len(self.samples) < count:
            assert time.monotonic() < deadline, f'the metrics node gave {len(self.samples)} ' \
                                                f'samples, not {count}'
            rclpy.spin_once(self.node, timeout_sec=0.1)


@pytest.fixture
def fake_world(ros_env):
    rclpy.init()
    world = FakeWorld()
    try:
        yield world
    finally:
        world.node.destroy_node()
        rclpy.try_shutdown()


def start_metrics_node(processes, out: Path, *parameters: str):
    command = ['metrics_node', '--ros-args', '-p', f'output_dir:={out}',
               '-p', 'finish_grace:=0.5']
    for parameter in parameters:
        command += ['-p', parameter]
    return processes.spawn(command, 'metrics')


def wait_for(condition, timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, f'timed out waiting for {what}'
        time.sleep(0.1)


def test_online_metrics_equal_embedded_and_offline(processes, fake_world, tmp_path):
    config = load_config().replace(episode={'population': 20, 'duration': 8.0, 'seed': 4},
                                   metrics={'sample_period': 0.5})
    node = start_metrics_node(processes, tmp_path / 'out', 'world_lost_after:=60.0',
                              'cue_map_period:=4.0')
    fake_world.wait_for_metrics_node()
    fake_world.run(config)
    bag_dir = tmp_path / 'out' / 'episode_0' / 'bag'
    wait_for(lambda: (bag_dir / 'metadata.yaml').exists(), 60, 'the bag to be closed')
    fake_world.say(fake_world.episode, {'episode': 0, 'shutdown': True})
    assert node.wait(60) == 0, processes.log('metrics')

    bag = read_episode_bag(bag_dir)
    assert bag.report.complete and bag.seed == 4
    assert bag.custom['mona_swarm.seed'] == '4'
    result = recompute(bag)
    expected = run_episode(config).metrics
    assert len(expected) == 17
    assert result.rows == expected  # offline == embedded, exactly
    assert result.online_rows == len(expected)
    assert result.online_max_diff == 0.0  # online == offline, exactly
    # maps at 0, 4 and 8 s (the last one because it is final), of those sent every 2 s
    assert result.cue_maps_checked == 3 and result.cue_map_max_diff == 0
    # poses decimated to the sample times; the cleaning events all kept
    assert bag.report.topics['/world/poses'] == len(expected) - 1
    assert bag.report.topics['/world/cleaning'] >= 5


@pytest.mark.parametrize('ending', ['world_lost', 'SIGTERM', 'SIGINT'])
def test_bag_is_closed_on_every_ending(processes, fake_world, tmp_path, ending):
    config = load_config().replace(episode={'population': 3, 'duration': 60.0, 'seed': 2})
    node = start_metrics_node(processes, tmp_path / 'out', 'world_lost_after:=5.0')
    fake_world.wait_for_metrics_node()
    fake_world.run(config, steps=100)
    bag_dir = tmp_path / 'out' / 'episode_0' / 'bag'
    wait_for(lambda: bag_dir.exists(), 30, 'the bag')
    if ending != 'world_lost':
        time.sleep(0.5)
        node.send_signal(getattr(signal, ending))
    status = node.wait(60)
    assert status == (3 if ending == 'world_lost' else 0), processes.log('metrics')
    bag = read_episode_bag(bag_dir)  # closed: complete, with its summary and metadata.yaml
    assert bag.report.complete and (bag_dir / 'metadata.yaml').exists()
    assert bag.seed == 2 and bag.parameters['episode']['population'] == 3
    assert find_mcap(bag_dir).name == 'bag.mcap'
    samples = bag.metric('mean_cue')[0]
    assert len(samples) == 4  # t = 0 .. 3 s of the 3.2 s published
    assert np.all(np.diff(samples) == 1_000_000_000)


def test_record_all_records_every_robot_topic(processes, fake_world, tmp_path):
    config = load_config().replace(episode={'population': 2, 'duration': 60.0, 'seed': 1})
    node = start_metrics_node(processes, tmp_path / 'out', 'record_all:=true')
    fake_world.wait_for_metrics_node()
    fake_world.run(config, steps=40)
    make = fake_world.node.create_publisher
    ground = [make(Image, qos.robot_topic(i, qos.GROUND), qos.SENSOR_QOS) for i in range(2)]
    cmd = make(TwistStamped, qos.robot_topic(1, qos.CMD_VEL), qos.COMMAND_QOS)
    cleaner = make(Bool, qos.robot_topic(0, qos.CLEANER), qos.CLEANER_QOS)
    wait_for(lambda: all(p.get_subscription_count() for p in (*ground, cmd, cleaner)), 60,
             'the per-robot subscriptions')
    for k in range(5):
        stamp = START_NS + (41 + k) * 32_000_000
        for i, publisher in enumerate(ground):
            msg = ground_image(i)
            msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(stamp, 10**9)
            publisher.publish(msg)
        twist = TwistStamped()
        fill_twist(twist, stamp, 0.08, 0.0)
        cmd.publish(twist)
        cleaner.publish(Bool(data=k % 2 == 0))
        time.sleep(0.05)
    time.sleep(1.0)
    node.send_signal(signal.SIGINT)
    assert node.wait(60) == 0, processes.log('metrics')
    bag = read_episode_bag(tmp_path / 'out' / 'episode_0' / 'bag')
    topics = bag.report.topics
    assert topics['/mona_0/ground'] == topics['/mona_1/ground'] == 5
    assert topics['/mona_1/cmd_vel'] == 5
    assert 1 <= topics['/mona_0/cleaner'] <= 5  # keep last 1: a state, not a stream
    assert topics['/world/poses'] == 2  # both sent; by default only the sampled one
