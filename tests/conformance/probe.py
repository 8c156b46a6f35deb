"""The conformance suite's own rclpy node: it announces the episodes and records everything a
world-side implementation publishes; two robots' scripted controllers (scripted.py) answer from
a process of their own, so that no answer waits behind the recording on a loaded machine, and
record their own readings, which the probe reads back (``Probe.take_record``).

Written against docs/interfaces.md with plain rclpy and the standard messages, not with the
project's decoding helpers (mona_controller.ros.messages, .ros.qos, .contract), so that the suite
checks an implementation, and those helpers, independently.

The scenario (``Scenario.run``), with robots 0-2 run by real controller nodes and robots 3
and 4 by scripted.py, with this module's constants:

- **episode 0** (the rules' episode): robot 3 subscribes to its readings only 1 s after the
  announcement, answers step 0 only after 2.5 s, answers step 10 once stamped for another
  step, then rightly, then again (a duplicate with another speed), answers step 31 (the
  first cleaning tick's) after 0.1 s turning its cleaner on (and saying state 2: waiting
  and cleaning; robot 4 never publishes a state), and drives at 5 cm/s for steps
  40-49; robot 4 answers steps 0-4 (cleaner on at step 4), is
  silent from step 5 and answers again from step 60.
- **episode 1**: announced with another ``mona.ir_range``: the world must refuse it.
- **episode 2**: a short episode at other poses, from the world's time then.
- then the shutdown announcement.
"""

from __future__ import annotations

import base64
import copy
import json
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import rclpy
from geometry_msgs.msg import PoseArray
from nav_msgs.msg import OccupancyGrid
from rclpy.executors import Executor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Image, LaserScan
from std_msgs.msg import String, UInt8MultiArray
from visualization_msgs.msg import MarkerArray

POPULATION = 5
CONTROLLED = (0, 1, 2)  #: robots whose controller is the real mona_controller_node
SCRIPTED = (3, 4)  #: robots scripted.py answers for
#: The scripted robots' node (scripted.py), which the probe waits for before the first episode.
SCRIPTED_NODE = 'conformance_scripted'

#: Episode 0's poses (x, y, yaw): robot 0 with the wall y = 0 on its right, robots 1 and 2
#: face to face 2 cm apart on the cue's slope, robot 3 with the wall x = 0 on its left, robot 4
#: alone in a corner.
POSES_0 = [[0.30, 0.06, 0.0], [1.00, 1.00, 0.0], [1.10, 1.00, np.pi], [0.06, 0.70, np.pi / 2],
           [2.50, 2.50, 0.0]]
POSES_2 = [[0.50, 0.30, 1.0], [1.30, 1.20, 0.5], [1.80, 1.60, 2.0], [0.40, 1.70, -1.0],
           [2.40, 0.50, 3.0]]
DURATION_0, DURATION_2 = 3.0, 0.5

ROBOT3_LISTENS_AFTER = 1.0  #: wall s after the announcement
ROBOT3_STEP0_DELAY = 2.5  #: wall s robot 3 keeps step 0 waiting
#: Robot 3 turns its cleaner on with its (late: the last) answer to the step that reaches the
#: first cleaning tick (31 x 32 ms -> 32 x 32 ms crosses 1 s).
ROBOT3_WRONG_STEP, ROBOT3_SLOW_STEP, ROBOT3_CLEANS_FROM = 10, 31, 31
ROBOT3_SLOW_DELAY = 0.1
ROBOT3_DRIVES = range(40, 50)  #: robot 3 drives forward at ROBOT3_SPEED for these steps
ROBOT3_SPEED = 0.05
ROBOT4_SILENT = range(5, 60)
#: The probe's history for the readings, the markers, the status, the maps, the sources and
#: the obstacles: deeper than
#: the page's keep last 5 or 1 (a subscriber's depth is its own, and a latched writer's depth
#: still bounds what a late subscriber gets), so a probe slowed down by a loaded machine loses
#: none that reached it (with depth 1 a status or map overwritten before the probe took it
#: failed the once-per-period rules under load, 2026-12-05; so did the sources sent with a map,
#: kept at depth 1 until ci47). What a probe stalled off the CPU
#: never received, the world's own keep-last history dropped: inner_suite.READINGS_RULES.
LISTENER_DEPTH = 200
ROBOT4_CLEANER_STEP = 4


def qos(depth: int, *, reliable: bool = True, latched: bool = False) -> QoSProfile:
    """The profile the page gives a topic (keep last ``depth``)."""
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=depth,
                      reliability=(ReliabilityPolicy.RELIABLE if reliable
                                   else ReliabilityPolicy.BEST_EFFORT),
                      durability=(DurabilityPolicy.TRANSIENT_LOCAL if latched
                                  else DurabilityPolicy.VOLATILE))


def ns_of(stamp) -> int:
    """A builtin_interfaces/Time as integer nanoseconds."""
    return stamp.sec * 1_000_000_000 + stamp.nanosec


def stamp_of(msg) -> int:
    """A message's stamp (ns); a MarkerArray's is its first marker's (-1 if empty)."""
    if hasattr(msg, 'markers'):
        return stamp_of(msg.markers[0]) if msg.markers else -1
    return ns_of(msg.header.stamp)


def poses_of(msg: PoseArray) -> np.ndarray:
    """[N, 3] (x, y, yaw) of a PoseArray (yaw from the z-axis quaternion)."""
    return np.array([[p.position.x, p.position.y,
                      2.0 * np.arctan2(p.orientation.z, p.orientation.w)] for p in msg.poses]
                    ).reshape(-1, 3)


class Probe(Node):
    """Records the world's topics (the scripted robots answer in scripted.py)."""

    def __init__(self, params: dict, **kwargs) -> None:
        super().__init__('conformance_probe', **kwargs)
        self.params = params
        self.step_ns = round(params['world']['step_period'] * 1e9)
        self.clock = time.monotonic
        #: (robot, 'ground' | 'proximity') -> [(received wall s, stamp ns, message)]
        self.readings: dict[tuple[int, str], list] = {}
        self.poses: list[tuple[float, int, np.ndarray]] = []
        self.cleaning: list[tuple[float, int, np.ndarray]] = []
        self.status: list[tuple[float, dict]] = []
        self.clock_ns: list[tuple[float, int]] = []
        self.latched: dict[str, list] = {'cue_map': [], 'cue_grid': [], 'markers': [],
                                         'obstacles': [], 'sources': []}
        self.robot_states: list[tuple[float, np.ndarray]] = []  #: (received, states)
        #: (robot, step) -> wall s a scripted robot began to send its answer (scripted.py's)
        self.sent: dict[tuple[int, int], float] = {}
        #: robot -> wall s its subscriptions were made (a scripted robot's: scripted.py's)
        self.listening: dict[int, float] = {}
        self.frames: set[tuple[str, str]] = set()  #: (topic, frame_id) seen
        self.create_subscription(PoseArray, '/world/poses', self._on_poses, qos(1000))
        self.create_subscription(PoseArray, '/world/cleaning', self._on_cleaning, qos(1000))
        self.create_subscription(String, '/world/status', self._on_status,
                                 qos(LISTENER_DEPTH, latched=True))
        self.create_subscription(Clock, '/clock', self._on_clock, qos(100, reliable=False))
        self.create_subscription(
            UInt8MultiArray, '/world/robot_states',
            lambda msg: self.robot_states.append((self.clock(), np.frombuffer(
                bytes(msg.data), np.uint8).copy())), qos(1000))
        for name, kind, profile in (
                ('cue_map', Image, qos(LISTENER_DEPTH, latched=True)),
                ('cue_grid', OccupancyGrid, qos(LISTENER_DEPTH, latched=True)),
                ('markers', MarkerArray, qos(LISTENER_DEPTH)),
                ('obstacles', MarkerArray, qos(LISTENER_DEPTH, latched=True)),
                ('sources', MarkerArray, qos(LISTENER_DEPTH, latched=True))):
            self.create_subscription(kind, f'/world/{name}',
                                     lambda msg, name=name: self.latched[name].append(
                                         (self.clock(), msg)), profile)
        self.episode_pub = self.create_publisher(String, '/episode', qos(1, latched=True))
        # The controllers' per-robot readings too (robots 0-2), as a second listener. Not the
        # scripted robots': theirs is the one subscription each that the world waits for
        # (scripted.py makes it 1 s after the announcement and records what comes); a second
        # one here would let the world start before they listen, or before this one's
        # proximity matched, so that it missed the first readings.
        for robot in CONTROLLED:
            self._listen(robot)

    # --- recording ----------------------------------------------------------------------

    def _listen(self, robot: int) -> None:
        self.listening[robot] = self.clock()
        for kind, msg_type in (('ground', Image), ('proximity', LaserScan)):
            self.readings[(robot, kind)] = self.readings.get((robot, kind), [])
            self.create_subscription(
                msg_type, f'/mona_{robot}/{kind}',
                lambda msg, robot=robot, kind=kind: self._on_reading(robot, kind, msg),
                qos(LISTENER_DEPTH))

    def _on_reading(self, robot: int, kind: str, msg) -> None:
        self.readings[(robot, kind)].append((self.clock(), ns_of(msg.header.stamp), msg))

    def _on_poses(self, msg: PoseArray) -> None:
        self.poses.append((self.clock(), ns_of(msg.header.stamp), poses_of(msg)))
        self.frames.add(('/world/poses', msg.header.frame_id))

    def _on_cleaning(self, msg: PoseArray) -> None:
        self.frames.add(('/world/cleaning', msg.header.frame_id))
        self.cleaning.append((self.clock(), ns_of(msg.header.stamp), poses_of(msg)))

    def _on_status(self, msg: String) -> None:
        self.status.append((self.clock(), json.loads(msg.data)))

    def _on_clock(self, msg: Clock) -> None:
        self.clock_ns.append((self.clock(), ns_of(msg.clock)))

    # --- episodes -----------------------------------------------------------------------

    def announce(self, document: dict) -> float:
        """Publish an announcement; returns the wall time it went out."""
        self.episode_pub.publish(String(data=json.dumps(document)))
        return self.clock()

    def latest_status(self) -> dict:
        """The last /world/status document received ({} before any)."""
        return self.status[-1][1] if self.status else {}

    def sees(self, node: str) -> bool:
        """Whether ``node`` subscribes to ``/episode`` in the graph this probe sees."""
        return any(info.node_name == node
                   for info in self.get_subscriptions_info_by_topic('/episode'))

    def take_record(self, path: Path) -> None:
        """Take in scripted.py's record (JSON lines): when each scripted robot subscribed, the
        readings it received (when, stamp, the message) and when it answered each step
        (nothing if it wrote none)."""
        types = {'ground': Image, 'proximity': LaserScan}
        lines = path.read_text().splitlines() if path.exists() else []
        for line in lines:
            try:
                item = json.loads(line)
            except json.JSONDecodeError:
                continue  # a line cut short by a kill
            if 'reading' in item:
                robot, kind = item['reading']
                msg = deserialize_message(base64.b64decode(item['cdr']), types[kind])
                self.readings.setdefault((robot, kind), []).append(
                    (item['at'], ns_of(msg.header.stamp), msg))
            elif 'sent' in item:
                self.sent[tuple(item['sent'])] = item['at']
            elif 'listening' in item:
                self.listening[item['listening']] = item['at']

    def endpoints(self) -> dict:
        """What the ROS graph says about every contract topic now: names and types, and per
        topic the other nodes' publishers and subscriptions (node, type, reliability,
        durability); the suite's own nodes (this probe, the scripted robots) left out."""
        ours = (self.get_name(), SCRIPTED_NODE)

        def describe(infos) -> list[tuple]:
            return [(info.node_name, info.topic_type, info.qos_profile.reliability,
                     info.qos_profile.durability) for info in infos
                    if info.node_name not in ours]

        names = dict(self.get_topic_names_and_types())
        graph = {'types': {name: list(types) for name, types in names.items()}}
        for name in names:
            graph[name] = {'publishers': describe(self.get_publishers_info_by_topic(name)),
                           'subscriptions': describe(
                               self.get_subscriptions_info_by_topic(name))}
        return graph


def announcement(episode: int, start_ns: int, poses: list, duration: float,
                 parameters: dict, seed: int = 7) -> dict:
    """An /episode document as docs/interfaces.md, "Episodes", gives it."""
    return {'episode': episode, 'seed': seed, 'population': len(poses), 'duration': duration,
            'start_ns': start_ns, 'poses': poses, 'parameters': parameters}


class Scenario:
    """Plays the module docstring's episodes against a running implementation."""

    def __init__(self, probe: Probe, executor: Executor,
                 world_alive: Callable[[], bool]) -> None:
        self.probe = probe
        self.executor = executor
        self.world_alive = world_alive
        self.log: list[str] = []
        self.marks: dict[str, float] = {}  #: event -> wall s
        self.announced: dict[int, dict] = {}
        self.graph: dict = {}

    def spin_until(self, condition: Callable[[], bool], timeout: float, what: str) -> bool:
        """Spin until ``condition`` holds; False (noted in :attr:`log`) after ``timeout``."""
        deadline = time.monotonic() + timeout
        while not condition():
            if time.monotonic() > deadline or not self.world_alive():
                self.log.append(f'gave up waiting for {what} after {timeout:g} s'
                                + ('' if self.world_alive() else ' (the world exited)'))
                return False
            self.executor.spin_once(timeout_sec=0.02)
        return True

    def settle(self, quiet: float = 0.5, limit: float = 5.0) -> None:
        """Spin until no message has arrived for ``quiet`` wall seconds (at most ``limit``):
        the last messages of an episode travel on several topics and may come late on a
        loaded machine."""
        probe = self.probe

        def count() -> int:
            return (len(probe.poses) + len(probe.robot_states) + len(probe.cleaning)
                    + len(probe.status) + sum(len(v) for v in probe.latched.values()))

        deadline = time.monotonic() + limit
        seen, since = count(), time.monotonic()
        while time.monotonic() < deadline and time.monotonic() - since < quiet:
            self.executor.spin_once(timeout_sec=0.02)
            if count() != seen:
                seen, since = count(), time.monotonic()

    def status_of(self, episode: int, *states: str) -> Callable[[], bool]:
        """A condition: the latest status is of ``episode`` in one of ``states``."""
        def holds() -> bool:
            latest = self.probe.latest_status()
            return latest.get('episode') == episode and latest.get('state') in states
        return holds

    def run(self) -> None:
        """The whole scenario; what did not happen is in :attr:`log`, for the tests."""
        probe = self.probe
        if not self.spin_until(lambda: bool(probe.status), 60, 'a first /world/status'):
            return
        parameters = copy.deepcopy(probe.params)
        first = announcement(0, int(probe.latest_status().get('time_ns', 0)), POSES_0,
                             DURATION_0, parameters)
        self.announced[0] = first
        if not self.spin_until(lambda: probe.sees(SCRIPTED_NODE), 30,
                               'the scripted robots (scripted.py) on /episode'):
            return
        self.marks['announced_0'] = probe.announce(first)
        if not self.spin_until(self.status_of(0, 'running', 'finished', 'failed'), 90,
                               'episode 0 running'):
            return
        self.spin_until(lambda: bool(probe.readings.get((0, 'proximity'))), 10, 'readings')
        self.graph = probe.endpoints()
        if not self.spin_until(self.status_of(0, 'finished', 'failed'), 120,
                               'episode 0 finished'):
            return
        end_ns = int(probe.latest_status().get('time_ns', 0))
        # The last poses (and their states) may be a reliable repair that comes after the
        # final status (Fast DDS resends a lost sample on its next heartbeat, about 3 s).
        since = self.marks['announced_0']

        def last_poses_in() -> bool:
            poses = [stamp for when, stamp, _ in probe.poses if when >= since]
            states = [row for when, row in probe.robot_states if when >= since]
            return end_ns in poses and len(states) <= len(poses)

        self.spin_until(last_poses_in, 10, "episode 0's last poses")
        self.settle()  # let the last ones land

        other = copy.deepcopy(parameters)
        other['mona']['ir_range'] = parameters['mona']['ir_range'] + 0.02
        self.announced[1] = announcement(1, end_ns, POSES_2, DURATION_2, other)
        self.marks['announced_1'] = probe.announce(self.announced[1])
        self.spin_until(self.status_of(1, 'failed'), 20, 'episode 1 refused')
        self.settle()

        start_2 = max(end_ns, int(probe.latest_status().get('time_ns', 0)))
        self.announced[2] = announcement(2, start_2, POSES_2, DURATION_2, parameters, seed=8)
        self.marks['announced_2'] = probe.announce(self.announced[2])
        if not self.spin_until(self.status_of(2, 'finished', 'failed'), 90,
                               'episode 2 finished'):
            return
        self.settle()
        self.marks['shutdown'] = probe.announce({'episode': 3, 'shutdown': True})


def spin_briefly(executor: Executor, seconds: float) -> None:
    """Spin ``executor`` for ``seconds`` of wall time."""
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        executor.spin_once(timeout_sec=0.02)


def init_context(domain: int) -> rclpy.Context:
    """An rclpy context of its own on ``domain``."""
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=domain)
    return context
