"""The world node's lockstep rules, with scripted controllers in this process."""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable

import numpy as np
import pytest
from geometry_msgs.msg import PoseArray, TwistStamped
from rclpy.node import Node
from rclpy.parameter import Parameter
from sensor_msgs.msg import Image, LaserScan
from std_msgs.msg import Bool, String

from mona_controller.ros import qos
from mona_controller.ros.messages import fill_twist, stamp_to_ns
from swarm_world.hosting import FINAL_FILE
from swarm_world.ros.world_messages import poses_from_pose_array
from swarm_world.ros.world_node import WorldNode
from swarm_world.world import World

pytestmark = pytest.mark.ros

STEP_NS = 32_000_000
START_NS = 1_000_000_000
POSES = [[0.5, 0.5, 0.0], [2.0, 2.0, math.pi / 2]]  # far apart: no contact, no IR hits

#: script(robot, step) -> the commands to send: (stamp offset in steps, linear speed m/s)
Script = Callable[[int, int], list[tuple[int, float]]]


class ScriptedRobots(Node):
    """Stand-in controllers: answer each ground reading as the script says."""

    def __init__(self, population: int, script: Script, **kwargs) -> None:
        super().__init__('scripted_robots', **kwargs)
        self.script = script
        self.steps_seen: list[int] = []
        self.on_step: Callable[[int], None] = lambda step: None
        self.on_answered: Callable[[int, int], None] = lambda robot, step: None
        self.cmd_pubs, self.cleaner_pubs = [], []
        for i in range(population):
            self.cleaner_pubs.append(self.create_publisher(
                Bool, qos.robot_topic(i, qos.CLEANER), qos.CLEANER_QOS))
            self.cmd_pubs.append(self.create_publisher(
                TwistStamped, qos.robot_topic(i, qos.CMD_VEL), qos.COMMAND_QOS))
        # Like the controller node: listen only once the world hears us (docs/interfaces.md).
        self.timer = self.create_timer(0.02, self.listen_when_heard)

    def listen_when_heard(self) -> None:
        if not all(p.get_subscription_count() for p in self.cmd_pubs + self.cleaner_pubs):
            return
        self.destroy_timer(self.timer)
        for i in range(len(self.cmd_pubs)):
            self.create_subscription(Image, qos.robot_topic(i, qos.GROUND),
                                     lambda msg, i=i: self.on_ground(i, msg), qos.SENSOR_QOS)
            self.create_subscription(LaserScan, qos.robot_topic(i, qos.PROXIMITY),
                                     lambda msg: None, qos.SENSOR_QOS)

    def on_ground(self, robot: int, msg: Image) -> None:
        stamp = stamp_to_ns(msg.header.stamp)
        step = (stamp - START_NS) // STEP_NS
        if robot == 0:
            self.steps_seen.append(step)
            self.on_step(step)
        for offset, linear in self.script(robot, step):
            self.cleaner_pubs[robot].publish(Bool(data=False))
            twist = TwistStamped()
            fill_twist(twist, stamp + offset * STEP_NS, linear, 0.0)
            self.cmd_pubs[robot].publish(twist)
        self.on_answered(robot, step)


class Observer(Node):
    """Announces the episode and records /world/poses and /world/status."""

    def __init__(self, **kwargs) -> None:
        super().__init__('observer', **kwargs)
        self.poses: dict[int, np.ndarray] = {}
        self.status: dict = {}
        self.episode_pub = self.create_publisher(String, qos.EPISODE, qos.EPISODE_QOS)
        self.create_subscription(PoseArray, qos.POSES, self.on_poses, qos.POSES_QOS)
        self.create_subscription(String, qos.STATUS,
                                 lambda msg: setattr(self, 'status', json.loads(msg.data)),
                                 qos.STATUS_QOS)

    def on_poses(self, msg: PoseArray) -> None:
        self.poses[(stamp_to_ns(msg.header.stamp) - START_NS) // STEP_NS] = \
            poses_from_pose_array(msg)

    def announce(self, steps: int) -> None:
        self.episode_pub.publish(String(data=json.dumps({
            'episode': 0, 'seed': 11, 'population': len(POSES), 'duration': steps * 0.032,
            'start_ns': START_NS, 'poses': POSES, 'parameters': {}})))


def start(executor, script: Script, tmp_path, **options) -> tuple[WorldNode, ScriptedRobots,
                                                                     Observer]:
    overrides = [Parameter('output_dir', value=str(tmp_path)),
                 Parameter('world.step_period', value=0.032)]
    overrides += [Parameter(name, value=value) for name, value in options.items()]
    world = WorldNode(context=executor.context, parameter_overrides=overrides)
    robots = ScriptedRobots(len(POSES), script, context=executor.context)
    observer = Observer(context=executor.context)
    for node in (world, robots, observer):
        executor.add_node(node)
    return world, robots, observer


def replay(world: WorldNode, commands: list[list[float]]) -> list[np.ndarray]:
    """The poses before each step and after the last one, from the core World itself."""
    core = World(world.params, world.mona, world.sensing)
    core.reset(np.array(POSES))
    poses = [core.poses.copy()]
    for linear in commands:
        core.step(np.array(linear), np.zeros(len(POSES)), np.zeros(len(POSES), dtype=bool))
        poses.append(core.poses.copy())
    return poses


def finished(observer: Observer) -> bool:
    return observer.status.get('state') == 'finished'


def test_lockstep_drops_stale_applies_duplicates_once_and_counts_a_miss(executor, spin_until,
                                                                        tmp_path):
    def script(robot: int, step: int) -> list[tuple[int, float]]:
        if robot == 1:
            return [] if step == 1 else [(0, 0.05)]  # robot 1 misses step 1
        if step == 1:  # the answer, a second one for the same step, one for the last step
            return [(0, 0.05), (0, 0.5), (-1, 0.5)]
        return [(0, 0.05)]

    world, robots, observer = start(executor, script, tmp_path, lockstep_deadline=0.5)
    observer.announce(steps=4)
    spin_until(lambda: finished(observer), what='episode finished')

    assert observer.status['misses'] == [0, 1]
    assert observer.status['dropped'] == 1
    assert observer.status['duplicates'] == 1
    assert robots.steps_seen == [0, 1, 2, 3]
    # The world moved exactly as the core does with these commands: robot 0 at its first
    # command of step 1 (not the duplicate's 0.5 m/s), robot 1 held still in step 1.
    poses = observer.poses
    assert sorted(poses) == [0, 1, 2, 3, 4]
    expected = replay(world, [[0.05, 0.05], [0.05, 0.0], [0.05, 0.05], [0.05, 0.05]])
    for step, pose in enumerate(expected):
        assert np.array_equal(poses[step], pose), step
    final = np.load(tmp_path / 'episode_0' / FINAL_FILE)
    assert final['misses'].tolist() == [0, 1] and int(final['dropped']) == 1
    assert int(final['seed']) == 11 and int(final['steps']) == 4
    assert np.array_equal(final['poses'], poses[4])
    assert final['cue'].dtype == np.float32 and final['poses'].dtype == np.float64


def test_a_silent_robot_becomes_absent_and_rejoins_when_it_answers(executor, spin_until,
                                                                   tmp_path):
    silent = range(2, 8)

    def script(robot: int, step: int) -> list[tuple[int, float]]:
        return [] if robot == 1 and step in silent else [(0, 0.05)]

    world, robots, observer = start(executor, script, tmp_path, lockstep_deadline=0.3,
                                    absent_after=2)
    seen: dict[int, tuple[list[int], list[int]]] = {}
    robots.on_step = lambda step: seen.setdefault(
        step, (world.lockstep.misses.tolist(), world.lockstep.counters()['absent']))
    observer.announce(steps=12)
    spin_until(lambda: finished(observer), what='episode finished')

    # Two misses (steps 2 and 3) made robot 1 absent; absent, it was not waited for and not
    # counted; it answered step 8 and was waited for again from then on.
    assert seen[4] == ([0, 2], [1])
    assert seen[7] == ([0, 2], [1])
    assert seen[10] == ([0, 2], [])
    assert observer.status['misses'] == [0, 2]
    assert observer.status['absent'] == []
    # Held still from step 2 until it was back (step 8 at the latest).
    commands = [[0.05, 0.05]] * 2 + [[0.05, 0.0]] * 6
    expected = replay(world, commands)
    for step, pose in enumerate(expected):
        assert np.array_equal(observer.poses[step], pose), step


def test_realtime_steps_on_the_wall_clock_with_the_latest_commands(executor, spin_until,
                                                                   tmp_path):
    def script(robot: int, step: int) -> list[tuple[int, float]]:
        return [(0, 0.05)] if robot == 0 else []  # robot 1 never answers

    world, robots, observer = start(executor, script, tmp_path, mode='realtime')
    observer.announce(steps=16)
    spin_until(lambda: finished(observer), what='episode finished')

    final = np.load(tmp_path / 'episode_0' / FINAL_FILE)
    assert int(final['steps']) == 16
    assert final['poses'][0, 0] > POSES[0][0] + 0.001  # drove forward (+x)
    assert np.array_equal(final['poses'][1], POSES[1])  # no command: held still
    assert observer.status['absent'] == [1] and observer.status['misses'][1] == 16


def test_a_deadline_after_a_stall_takes_the_answers_already_waiting(executor, spin_until,
                                                                   tmp_path):
    """The executor runs a ready timer before ready subscriptions: after a stall longer than
    the deadline, the answers of the round are waiting when the deadline fires. They count."""
    def script(robot: int, step: int) -> list[tuple[int, float]]:
        return [(0, 0.05)]

    world, robots, observer = start(executor, script, tmp_path, lockstep_deadline=0.3)
    # Both robots answer step 2, then the process stalls past the deadline (as a swapped-out
    # process would) before the world's callbacks run again.
    robots.on_answered = lambda robot, step: time.sleep(0.8) if (robot, step) == (1, 2) else None
    observer.announce(steps=5)
    spin_until(lambda: finished(observer), what='episode finished')

    assert observer.status['misses'] == [0, 0]
    expected = replay(world, [[0.05, 0.05]] * 5)
    for step, pose in enumerate(expected):
        assert np.array_equal(observer.poses[step], pose), step
