"""The topic contract as one table: per topic its name, message type, QoS, publisher and role.

Plain data, ROS-free: :mod:`mona_controller.ros.qos` builds the rclpy profiles from it, the bag
writers their offered QoS and topic list, the live view its channels, and the nodes their
subscriptions, so no consumer writes a type or a QoS again. docs/interfaces.md explains each
topic; ``tests/unit/test_topics.py`` holds every consumer's view to this table.

Names come in three kinds:

* absolute (``/world/poses``): one topic;
* relative (``ground``): one per robot, in the robot's namespace ``/mona_<i>``
  (:func:`robot_topic`);
* a prefix ending in ``/`` (``/metrics/``): one topic per metric of the metrics table
  (``swarm_metrics.metrics.METRICS``), ``/metrics/<name>``, all alike.
"""

from __future__ import annotations

import dataclasses
import re

# Per robot, relative to the namespace /mona_<i>.
GROUND = 'ground'
PROXIMITY = 'proximity'
CMD_VEL = 'cmd_vel'
CLEANER = 'cleaner'
STATE = 'state'

# World, supervisor, recorders and metrics (absolute).
CLOCK = '/clock'
POSES = '/world/poses'
CLEANING = '/world/cleaning'
CUE_MAP = '/world/cue_map'
CUE_GRID = '/world/cue_grid'
MARKERS = '/world/markers'
OBSTACLES = '/world/obstacles'
STATUS = '/world/status'
ROBOT_STATES = '/world/robot_states'
SOURCES = '/world/sources'
EPISODE = '/episode'
RECORDERS = '/recorders'
METRICS_PREFIX = '/metrics/'

# Who publishes a topic.
WORLD = 'world'  #: the world node, or a real robot's driver
CONTROLLER = 'controller'  #: each robot's controller node
SUPERVISOR = 'supervisor'
METRICS = 'metrics'  #: the metrics node (and the embedded runner's bag recorder)

_ROBOT_TOPIC = re.compile(r'/mona_\d+/([^/]+)')


@dataclasses.dataclass(frozen=True)
class QoS:
    """A topic's QoS as plain data: keep-last ``depth``, reliable or best effort, latched
    (transient local: a late joiner gets the latest ``depth`` messages) or volatile."""

    depth: int
    reliable: bool = True
    latched: bool = False


@dataclasses.dataclass(frozen=True)
class Topic:
    """One entry of the contract."""

    name: str  #: absolute, relative (per robot) or a prefix ending in '/' (per metric)
    type: str  #: the message type, e.g. 'geometry_msgs/msg/PoseArray'
    qos: QoS
    publisher: str  #: :data:`WORLD`, :data:`CONTROLLER`, :data:`SUPERVISOR`, ...
    recorded: bool  #: an episode's bag records it by default (the rest: ``record_all``)
    live: bool  #: the Foxglove live view carries it
    doc: str  #: one line

    @property
    def per_robot(self) -> bool:
        """One topic per robot, in its namespace."""
        return not self.name.startswith('/')

    @property
    def per_metric(self) -> bool:
        """One topic per metric, ``<prefix><metric>``."""
        return self.name.endswith('/')


def _topic(name: str, type: str, depth: int, publisher: str, doc: str, *,
           reliable: bool = True, latched: bool = False, recorded: bool = False,
           live: bool = False) -> Topic:
    return Topic(name, type, QoS(depth, reliable, latched), publisher, recorded, live, doc)


#: Every topic of the contract, by name, in the order docs/interfaces.md lists them.
TOPICS: dict[str, Topic] = {topic.name: topic for topic in (
    # Every reading and every answer must arrive (lockstep).
    _topic(GROUND, 'sensor_msgs/msg/Image', 5, WORLD,
           'the cue under the left and the right wheel'),
    _topic(PROXIMITY, 'sensor_msgs/msg/LaserScan', 5, WORLD, 'the front IR ring'),
    _topic(CMD_VEL, 'geometry_msgs/msg/TwistStamped', 5, CONTROLLER,
           'the answer to the readings of the same stamp'),
    # The cleaning actuator is a state: a late joiner gets the latest one.
    _topic(CLEANER, 'std_msgs/msg/Bool', 1, CONTROLLER, 'the cleaning actuator',
           latched=True),
    # The behaviour behind the answer, for observers: a state like the cleaner (the world
    # keeps each robot's latest and gathers them on /world/robot_states).
    _topic(STATE, 'std_msgs/msg/UInt8', 1, CONTROLLER,
           "the controller's state after its latest answer", latched=True),
    # The ROS clock QoS (rclpy's time source subscribes best effort, depth 1).
    _topic(CLOCK, 'rosgraph_msgs/msg/Clock', 1, WORLD, 'sim time', reliable=False,
           recorded=True, live=True),
    # The metrics must see every pose and cleaning event: a deep history lets a metrics node
    # that falls behind on a loaded machine catch up (about 30 s of steps) instead of losing
    # the pose of a sample time.
    _topic(POSES, 'geometry_msgs/msg/PoseArray', 1000, WORLD, 'ground-truth poses',
           recorded=True, live=True),
    _topic(CLEANING, 'geometry_msgs/msg/PoseArray', 1000, WORLD,
           'the poses of the robots that cleaned at a cleaning tick', recorded=True),
    # The cue map, its grid, the status and the announcement: the latest value, kept for
    # late joiners.
    _topic(CUE_MAP, 'sensor_msgs/msg/Image', 1, WORLD, 'the cue raster (mono8)',
           latched=True, recorded=True, live=True),
    _topic(CUE_GRID, 'nav_msgs/msg/OccupancyGrid', 1, WORLD,
           'the cue raster as an occupancy grid, for map overlays', latched=True, live=True),
    _topic(MARKERS, 'visualization_msgs/msg/MarkerArray', 1, WORLD,
           'one cylinder per robot, coloured by what it does', live=True),
    # Static scenery: published once, latched (what RViz and Foxglove expect of it); every
    # bag records it at its episode's start.
    _topic(OBSTACLES, 'visualization_msgs/msg/MarkerArray', 1, WORLD,
           "the arena's obstacles, one grey marker each", latched=True, recorded=True,
           live=True),
    _topic(STATUS, 'std_msgs/msg/String', 1, WORLD, "the world's status (JSON)",
           latched=True, recorded=True, live=True),
    # One message per /world/poses message, published just before it: the recorder pairs
    # the n-th of each (the array has no stamp), so it keeps as deep a history as the poses.
    _topic(ROBOT_STATES, 'std_msgs/msg/UInt8MultiArray', 1000, WORLD,
           "each robot's controller state, with each /world/poses", recorded=True, live=True),
    # The sources move (world.source_velocity, source_path): published with the cue map.
    _topic(SOURCES, 'visualization_msgs/msg/MarkerArray', 1, WORLD,
           'the leak sources where they are, one marker each', latched=True, recorded=True,
           live=True),
    _topic(EPISODE, 'std_msgs/msg/String', 1, SUPERVISOR,
           'the episode announcement or the shutdown (JSON)', latched=True, recorded=True,
           live=True),
    # Each recorder's latest kept for late joiners; several recorders (and a burst of
    # progress reports) must not push a "recording" out of a subscriber's history.
    _topic(RECORDERS, 'std_msgs/msg/String', 10, METRICS,
           "each recorder's word on its record of an episode (JSON)", latched=True),
    _topic(METRICS_PREFIX, 'std_msgs/msg/Float64', 10, METRICS,
           'one metric, once per sample period', recorded=True, live=True),
)}


def robot_namespace(robot_id: int) -> str:
    """The namespace of robot ``robot_id`` (ROS names must not start with a digit)."""
    return f'/mona_{robot_id}'


def robot_topic(robot_id: int, name: str) -> str:
    """The absolute name of a per-robot topic, e.g. ``/mona_3/cmd_vel``."""
    return f'{robot_namespace(robot_id)}/{name}'


def metric_topic(name: str) -> str:
    """The topic of metric ``name``, e.g. ``/metrics/coherency``."""
    return METRICS_PREFIX + name


def topic_of(name: str) -> Topic | None:
    """The entry an absolute topic name belongs to (``/mona_3/cmd_vel`` -> ``cmd_vel``,
    ``/metrics/coherency`` -> ``/metrics/``), or None for a name outside the contract."""
    topic = TOPICS.get(name)
    if topic is not None and not topic.per_robot and not topic.per_metric:
        return topic
    if name.startswith(METRICS_PREFIX) and len(name) > len(METRICS_PREFIX):
        return TOPICS[METRICS_PREFIX]
    match = _ROBOT_TOPIC.fullmatch(name)
    topic = TOPICS.get(match.group(1)) if match else None
    return topic if topic is not None and topic.per_robot else None


def expand(topics: dict[str, Topic], metric_names: tuple[str, ...]) -> dict[str, Topic]:
    """``topics`` with the per-metric entry replaced by one per metric (in place, in order).

    Args:
        topics: entries of :data:`TOPICS` (or a selection of them).
        metric_names: the metrics, in column order.

    Returns:
        absolute topic name -> its entry.
    """
    out: dict[str, Topic] = {}
    for name, topic in topics.items():
        if topic.per_metric:
            out.update((name + metric, topic) for metric in metric_names)
        else:
            out[name] = topic
    return out


def recorded() -> dict[str, Topic]:
    """The entries a default bag records (the per-metric one not yet expanded)."""
    return {name: topic for name, topic in TOPICS.items() if topic.recorded}


def live() -> dict[str, Topic]:
    """The entries the live view carries (the per-metric one not yet expanded)."""
    return {name: topic for name, topic in TOPICS.items() if topic.live}
