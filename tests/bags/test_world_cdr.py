"""The world's messages built without ROS (swarm_world.messages.cdr) against rclpy's own
serialization of the world node's messages: the same bytes, padding aside."""

from __future__ import annotations

import numpy as np
import pytest
from rclpy.serialization import serialize_message
from rosgraph_msgs.msg import Clock
from std_msgs.msg import Float64, String

from mona_controller.contract import WorldState, WorldStatus
from mona_controller.controllers.beeclust import STATES
from mona_controller.mona import MonaParams
from mona_controller.ros.messages import set_stamp
from swarm_supervisor.outputs.bag import status_json
from swarm_world.arena import Arena, Disc, Polygon, Rect
from swarm_world.field import CueField
from swarm_world.messages.cdr import (
    TYPESTORE,
    clock_cdr,
    cue_grid_cdr,
    cue_image_cdr,
    float64_cdr,
    markers_cdr,
    obstacles_cdr,
    pose_array_cdr,
    sources_cdr,
    states_cdr,
    states_from_cdr,
    string_cdr,
)
from swarm_world.messages.markers import SPHERE, sources_from_markers
from swarm_world.params import WorldParams
from swarm_world.ros.world_messages import (
    PoseArrayFiller,
    cue_grid,
    cue_image,
    obstacle_markers,
    robot_markers,
    robot_states,
    source_markers,
)
from swarm_world.sensing.params import SensingParams

pytestmark = pytest.mark.ros

#: BEECLUST's states' colours, by code.
PALETTE = [state.colour for state in STATES]
NS = 12_345_678_901


def same_but_padding(ours: bytes, theirs: bytes, msgtype: str) -> None:
    assert len(ours) == len(theirs)
    assert sum(a != b for a, b in zip(ours, theirs)) <= 3  # alignment bytes rclpy leaves
    assert ours[48:] == theirs[48:]  # the payload, after the headers' alignment bytes
    assert TYPESTORE.serialize_cdr(TYPESTORE.deserialize_cdr(ours, msgtype), msgtype) == \
        TYPESTORE.serialize_cdr(TYPESTORE.deserialize_cdr(theirs, msgtype), msgtype)


@pytest.mark.parametrize('n', [0, 1, 7, 50])
def test_pose_arrays_are_rclpy_bytes(n):
    poses = np.random.default_rng(n).uniform(-3, 3, (n, 3))
    theirs = bytes(serialize_message(PoseArrayFiller().fill(poses, NS)))
    # rclpy leaves whatever was in memory in the alignment bytes after the frame id.
    same_but_padding(pose_array_cdr(poses, NS), theirs, 'geometry_msgs/msg/PoseArray')


def test_cue_map_and_grid_are_rclpy_bytes_but_padding():
    cue = np.random.default_rng(1).uniform(0, 255, (37, 41)).astype(np.float32)
    same_but_padding(cue_image_cdr(cue, NS), bytes(serialize_message(cue_image(cue, NS))),
                     'sensor_msgs/msg/Image')
    same_but_padding(cue_grid_cdr(cue, 0.01, NS),
                     bytes(serialize_message(cue_grid(cue, 0.01, NS))),
                     'nav_msgs/msg/OccupancyGrid')


def test_small_messages_are_rclpy_bytes():
    clock = Clock()
    set_stamp(clock.clock, NS)
    assert clock_cdr(NS) == bytes(serialize_message(clock))
    assert string_cdr('{"é": 1}') == bytes(serialize_message(String(data='{"é": 1}')))
    for value in (0.1, 0.0, -1.5, 255.0, float('inf')):
        assert float64_cdr(value) == bytes(serialize_message(Float64(data=value)))
    states = np.array([0, 1, 2, 3, 2], dtype=np.uint8)
    assert states_from_cdr(states_cdr(states)).tolist() == states.tolist()
    poses = np.random.default_rng(5).uniform(0, 2.85, (5, 3))
    markers = TYPESTORE.deserialize_cdr(markers_cdr(poses, states, 0.04, NS, palette=PALETTE),
                                        'visualization_msgs/msg/MarkerArray').markers
    assert [m.id for m in markers] == list(range(5))
    assert [(m.pose.position.x, m.pose.position.y) for m in markers] == \
        [tuple(p) for p in poses[:, :2].tolist()]
    assert [(m.color.r, m.color.g, m.color.b) for m in markers] == \
        [tuple(np.float32(c)) for c in np.array(PALETTE)[states, :3]]
    assert {(m.header.stamp.sec, m.header.stamp.nanosec, m.header.frame_id, m.scale.x)
            for m in markers} == {(12, 345_678_901, 'world', 0.08)}
    # Built by tiling one marker's bytes: equal to the type store's own serialization.
    assert markers_cdr(poses, states, 0.04, NS, palette=PALETTE) == TYPESTORE.serialize_cdr(
        TYPESTORE.types['visualization_msgs/msg/MarkerArray'](markers=markers),
        'visualization_msgs/msg/MarkerArray')


def test_the_recorder_status_text_is_the_contract_text():
    status = WorldStatus(3, WorldState.FINISHED, step=7, steps=9, time_ns=NS, mode='embedded',
                         misses=(0, 1, 2), absent=(1,), cleaning_events=4, error='x')
    assert status_json(status) == status.to_json()


def test_obstacle_markers_are_rclpy_bytes():
    """The world node's /world/obstacles and the embedded runner's are the same message."""
    arena = Arena(2.85, (Disc('a', 1.0, 1.0, 0.1), Rect.of('b', 2.2, 0.3, 2.26, 1.1),
                         Polygon('c', ((0.3, 2.3), (0.7, 2.5), (0.35, 2.6)))))
    for case in (arena, Arena(2.85)):
        ours, theirs = obstacles_cdr(case), bytes(serialize_message(obstacle_markers(case)))
        msgtype = 'visualization_msgs/msg/MarkerArray'
        assert len(ours) == len(theirs)
        # Padding aside: both decode to the same message.
        assert TYPESTORE.serialize_cdr(TYPESTORE.deserialize_cdr(ours, msgtype), msgtype) == \
            TYPESTORE.serialize_cdr(TYPESTORE.deserialize_cdr(theirs, msgtype), msgtype)
    assert obstacles_cdr(Arena(2.85)) == bytes(serialize_message(obstacle_markers(Arena(2.85))))


def test_robot_states_are_rclpy_bytes():
    """The world node's /world/robot_states and the embedded runner's: the same bytes."""
    for states in (np.array([0, 1, 2, 3, 2], dtype=np.int8), np.zeros(0, dtype=np.int8),
                   np.full(50, 2, dtype=np.int8)):
        assert states_cdr(states) == bytes(serialize_message(robot_states(states)))
        assert states_from_cdr(states_cdr(states)).tolist() == states.tolist()


def test_source_markers_are_rclpy_bytes_and_move_with_the_sources():
    """/world/sources of the world node and of the embedded runner: the same message, one
    sphere per source (name order) where CueField puts it at the stamp's time."""
    world = WorldParams(sources={'west': [0.8, 2.0, 0.5, 255.0], 'east': [2.1, 0.9, 0.6, 255.0]},
                        source_velocity={'west': [0.02, -0.01]},
                        source_path={'east': [0.03, 2.1, 1.9, 1.5, 1.4]})
    field = CueField(world, MonaParams(), SensingParams())
    msgtype = 'visualization_msgs/msg/MarkerArray'
    shown = []
    for t in (0.0, 7.5, 30.0):
        positions = field.source_positions(t)
        ours = sources_cdr(field.names, positions, NS)
        theirs = bytes(serialize_message(source_markers(field.names, positions, NS)))
        assert len(ours) == len(theirs)
        assert TYPESTORE.serialize_cdr(TYPESTORE.deserialize_cdr(ours, msgtype), msgtype) == \
            TYPESTORE.serialize_cdr(TYPESTORE.deserialize_cdr(theirs, msgtype), msgtype)
        markers = TYPESTORE.deserialize_cdr(ours, msgtype).markers
        assert [(m.ns, m.id, m.type, m.header.frame_id) for m in markers] == \
            [('sources', 0, SPHERE, 'world'), ('sources', 1, SPHERE, 'world')]
        assert {(m.header.stamp.sec, m.header.stamp.nanosec) for m in markers} == \
            {(12, 345_678_901)}
        shown.append(sources_from_markers(markers))
        assert shown[-1] == tuple((name, x, y) for name, (x, y)
                                  in zip(field.names, positions.tolist()))
    assert [s[0] for s in shown[0]] == ['east', 'west']
    assert shown[0] != shown[1] != shown[2]  # they move


def test_robot_markers_of_both_runners_are_the_same_message():
    """The world node's /world/markers, coloured by the states it gathers, and the embedded
    live view's: the same markers (padding aside)."""
    poses = np.random.default_rng(3).uniform(0, 2.85, (6, 3))
    states = np.array([0, 1, 2, 3, 2, 0], dtype=np.uint8)
    msgtype = 'visualization_msgs/msg/MarkerArray'
    ours = markers_cdr(poses, states, 0.04, NS, palette=PALETTE)
    theirs = bytes(serialize_message(robot_markers(poses, states, 0.04, NS, palette=PALETTE)))
    assert len(ours) == len(theirs)
    assert TYPESTORE.serialize_cdr(TYPESTORE.deserialize_cdr(ours, msgtype), msgtype) == \
        TYPESTORE.serialize_cdr(TYPESTORE.deserialize_cdr(theirs, msgtype), msgtype)
