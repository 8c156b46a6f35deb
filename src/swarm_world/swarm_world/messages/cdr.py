"""The world's messages as CDR bytes, without ROS: what the embedded runner records and serves.

The world node publishes rclpy messages and the metrics node records the CDR bytes that
arrive; the embedded runner has no rclpy, so it builds the same messages here with rosbags'
Jazzy type store (and numpy for the big ones), byte for byte what rclpy sends except for
padding bytes, which no reader looks at. The bag writer, the embedded recorder and the live
view all take their bytes from here, so a bag and the live view carry the same messages.
"""

from __future__ import annotations

import functools
import json
import struct
from collections.abc import Sequence
from typing import Any

import numpy as np
from rosbags.typesys import Stores, get_typestore

from mona_controller.contract import WORLD_FRAME
from swarm_world.arena import Arena
from swarm_world.messages import markers as arena_markers
from swarm_world.messages.cue_map import cue_mono8, cue_percent

#: The message types of ROS 2 Jazzy: the world's messages are built with them, and every bag
#: is written and read with them.
TYPESTORE = get_typestore(Stores.ROS2_JAZZY)
TYPES = TYPESTORE.types
STRING = 'std_msgs/msg/String'
FLOAT64 = 'std_msgs/msg/Float64'
UINT8_ARRAY = 'std_msgs/msg/UInt8MultiArray'
CLOCK_TYPE = 'rosgraph_msgs/msg/Clock'
POSE_ARRAY = 'geometry_msgs/msg/PoseArray'
IMAGE = 'sensor_msgs/msg/Image'
OCCUPANCY_GRID = 'nav_msgs/msg/OccupancyGrid'
MARKER_ARRAY = 'visualization_msgs/msg/MarkerArray'
#: Little-endian CDR's encapsulation header (what rclpy writes on this machine).
CDR_LE = b'\x00\x01\x00\x00'


def serialize(msg: object, msgtype: str) -> bytes:
    """Any message of the Jazzy type store as little-endian CDR."""
    return bytes(TYPESTORE.serialize_cdr(msg, msgtype))


def _time(ns: int) -> Any:
    return TYPES['builtin_interfaces/msg/Time'](sec=ns // 1_000_000_000,
                                                nanosec=ns % 1_000_000_000)


def _header(ns: int, frame: str = WORLD_FRAME) -> Any:
    return TYPES['std_msgs/msg/Header'](stamp=_time(ns), frame_id=frame)


def _header_cdr(ns: int, frame: str) -> bytes:
    """A Header's CDR after the encapsulation: stamp, then the frame id (NUL-terminated)."""
    name = frame.encode() + b'\x00'
    return struct.pack('<iII', ns // 1_000_000_000, ns % 1_000_000_000, len(name)) + name


def string_cdr(text: str) -> bytes:
    """std_msgs/String."""
    name = text.encode() + b'\x00'
    return CDR_LE + struct.pack('<I', len(name)) + name


def json_cdr(document: dict[str, Any]) -> bytes:
    """A JSON document as std_msgs/String (the announcement, the status)."""
    return string_cdr(json.dumps(document))


def float64_cdr(value: float) -> bytes:
    """std_msgs/Float64."""
    return CDR_LE + struct.pack('<d', value)


def clock_cdr(ns: int) -> bytes:
    """rosgraph_msgs/Clock at ``ns``."""
    return CDR_LE + struct.pack('<iI', ns // 1_000_000_000, ns % 1_000_000_000)


def pose_array_cdr(poses: np.ndarray, ns: int, frame: str = WORLD_FRAME) -> bytes:
    """geometry_msgs/PoseArray of [N, 3] poses (x, y, yaw; yaw as a z-axis quaternion), as the
    world node fills it (swarm_world.ros.world_messages.PoseArrayFiller), in one numpy pass."""
    poses = np.asarray(poses, dtype=np.float64).reshape(-1, 3)
    head = _header_cdr(ns, frame)
    head += b'\x00' * (-len(head) % 4) + struct.pack('<I', len(poses))
    if len(poses):  # each Pose starts with a float64 (rclpy pads nothing before none)
        head += b'\x00' * (-len(head) % 8)
    body = np.zeros((len(poses), 7))
    body[:, 0:2] = poses[:, 0:2]
    # Half-angle quaternion about z, as swarm_world.frames.yaw_to_quaternion.
    body[:, 5] = np.sin(poses[:, 2] / 2)
    body[:, 6] = np.cos(poses[:, 2] / 2)
    return CDR_LE + head + body.astype('<f8').tobytes()


def cue_image_cdr(cue: np.ndarray, ns: int) -> bytes:
    """sensor_msgs/Image mono8 of the cue, row 0 at the **top** (max y), as /world/cue_map."""
    rows, cols = cue.shape
    head = _header_cdr(ns, WORLD_FRAME)
    head += b'\x00' * (-len(head) % 4) + struct.pack('<II', rows, cols)
    encoding = b'mono8\x00'
    head += struct.pack('<I', len(encoding)) + encoding
    head += struct.pack('<B', 0)  # is_bigendian
    head += b'\x00' * (-len(head) % 4) + struct.pack('<II', cols, rows * cols)  # step, data
    return CDR_LE + head + cue_mono8(cue)[::-1].tobytes()


def cue_grid_cdr(cue: np.ndarray, cell_size: float, ns: int) -> bytes:
    """nav_msgs/OccupancyGrid of the cue scaled to 0..100, origin at the world origin (as
    /world/cue_grid: a map overlay in Foxglove's 3D panel)."""
    rows, cols = cue.shape
    scaled = cue_percent(cue)
    # By hand: the type store's serializer takes milliseconds even for the empty grid.
    head = _header_cdr(ns, WORLD_FRAME)
    head += b'\x00' * (-len(head) % 4)
    head += struct.pack('<iIfII', ns // 1_000_000_000, ns % 1_000_000_000, cell_size, cols,
                        rows)  # MapMetaData: map_load_time, resolution, width, height
    head += b'\x00' * (-len(head) % 8)
    head += struct.pack('<7d', 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)  # origin: the world's
    return CDR_LE + head + struct.pack('<I', scaled.size) + scaled.tobytes()


def states_cdr(states: np.ndarray) -> bytes:
    """std_msgs/UInt8MultiArray: each robot's controller state (0 follow, 1 avoid, 2 wait,
    3 turn), robot i at index i (``/world/robot_states``)."""
    data = np.asarray(states, dtype=np.uint8)
    # MultiArrayLayout with no dimensions and offset 0, then the bytes.
    return CDR_LE + struct.pack('<III', 0, 0, len(data)) + data.tobytes()


def states_from_cdr(data: bytes) -> np.ndarray:
    """The states of a ``/world/robot_states`` message."""
    message: Any = TYPESTORE.deserialize_cdr(data, UINT8_ARRAY)
    return np.asarray(message.data, dtype=np.uint8)


def stamp_ns(data: bytes) -> int:
    """The stamp of a serialized message whose first field is a Time (a Header, a Clock).

    Reads the CDR bytes directly (encapsulation, then sec int32 and nanosec uint32), so a
    recorded message needs no deserialization.
    """
    sec: int
    nanosec: int
    sec, nanosec = struct.unpack_from('<iI' if data[1] == 1 else '>iI', data, 4)
    return sec * 1_000_000_000 + nanosec


def markers_stamp_ns(data: bytes) -> int | None:
    """The stamp of a serialized MarkerArray's first marker (None: no markers)."""
    big = data[1] != 1
    (count,) = struct.unpack_from('>I' if big else '<I', data, 4)
    if count == 0:
        return None
    sec: int
    nanosec: int
    sec, nanosec = struct.unpack_from('>iI' if big else '<iI', data, 8)
    return sec * 1_000_000_000 + nanosec


def _marker(stamp_ns: int, robot: int, x: float, y: float, colour: tuple[float, ...],
            body_radius: float) -> Any:
    """One robot's cylinder marker."""
    height = arena_markers.ROBOT_HEIGHT
    return _any_marker(stamp_ns, 'robots', robot, arena_markers.CYLINDER, (x, y, height / 2),
                       (2 * body_radius, 2 * body_radius, height), colour)


def _any_marker(stamp_ns: int, namespace: str, marker_id: int, kind: int,
                position: tuple[float, float, float], scale: tuple[float, float, float],
                colour: tuple[float, ...], points: tuple[Any, ...] = (),
                text: str = '') -> Any:
    """A visualization_msgs/Marker (action ADD, identity orientation, frame world)."""
    point, quaternion = TYPES['geometry_msgs/msg/Point'], TYPES['geometry_msgs/msg/Quaternion']
    x, y, z = position
    return TYPES['visualization_msgs/msg/Marker'](
        header=_header(stamp_ns), ns=namespace, id=marker_id, type=kind, action=0,  # ADD
        pose=TYPES['geometry_msgs/msg/Pose'](
            position=point(x=x, y=y, z=z),
            orientation=quaternion(x=0.0, y=0.0, z=0.0, w=1.0)),
        scale=TYPES['geometry_msgs/msg/Vector3'](x=scale[0], y=scale[1], z=scale[2]),
        color=TYPES['std_msgs/msg/ColorRGBA'](r=colour[0], g=colour[1], b=colour[2],
                                              a=colour[3]),
        lifetime=TYPES['builtin_interfaces/msg/Duration'](sec=0, nanosec=0),
        frame_locked=False, points=[point(x=px, y=py, z=pz) for px, py, pz in points],
        colors=[], texture_resource='',
        texture=TYPES['sensor_msgs/msg/CompressedImage'](
            header=_header(0, ''), format='', data=np.zeros(0, dtype=np.uint8)),
        uv_coordinates=[], text=text, mesh_resource='',
        mesh_file=TYPES['visualization_msgs/msg/MeshFile'](
            filename='', data=np.zeros(0, dtype=np.uint8)),
        mesh_use_embedded_materials=False)


def obstacles_cdr(arena: Arena) -> bytes:
    """visualization_msgs/MarkerArray ``/world/obstacles``: one grey marker per obstacle of
    ``arena`` (:mod:`swarm_world.messages.markers`), stamp 0; no obstacles, no markers. Built
    from the same marker data as the world node's message."""
    return _marker_array_cdr(arena_markers.obstacle_markers(arena), arena_markers.NAMESPACE,
                             arena_markers.COLOUR, 0)


def sources_cdr(names: tuple[str, ...], positions: np.ndarray, ns: int) -> bytes:
    """visualization_msgs/MarkerArray ``/world/sources``: one sphere per source at
    ``positions`` [S, 2], stamped ``ns``; the same marker data as the world node's message
    (:func:`swarm_world.messages.markers.source_markers`)."""
    return _marker_array_cdr(arena_markers.source_markers(names, positions.tolist()),
                             arena_markers.SOURCES_NAMESPACE, arena_markers.SOURCE_COLOUR, ns)


def _marker_array_cdr(markers: tuple[arena_markers.MarkerData, ...], namespace: str,
                      colour: tuple[float, ...], ns: int) -> bytes:
    array = [_any_marker(ns, namespace, data.id, data.type, data.position, data.scale, colour,
                         data.points, data.text) for data in markers]
    return serialize(TYPES[MARKER_ARRAY](markers=array), MARKER_ARRAY)


# Sentinels that locate the varying fields of a serialized marker (see _marker_layout).
_ID, _X, _Y, _RGBA = 0x5EA5EA11, 1234.5678, 8765.4321, (0.125, 0.375, 0.625, 0.875)


#: Where a marker's varying fields sit in its block (checked by _marker_layout).
_MARKER_OFFSETS = {'id': 32, 'x': 44, 'y': 52, 'rgba': 124}


@functools.cache
def _marker_layout(body_radius: float) -> tuple[int, int, bytes]:
    """(bytes per marker with the padding after it, that padding, a marker's block with
    stamp 0, id, x, y and colour to be written in at :data:`_MARKER_OFFSETS`).

    Every marker serializes to the same number of bytes and needs no padding between
    markers (checked here), so N markers are one block tiled N times with those fields
    written in: what the type store builds with thousands of Python objects, numpy does in
    one pass.
    """
    blocks = []
    for count in (1, 3):
        array = TYPES[MARKER_ARRAY](markers=[_marker(0, _ID, _X, _Y, _RGBA, body_radius)] * count)
        blocks.append(serialize(array, MARKER_ARRAY))
    # A marker ends with a bool and the next begins with an int32: 4-byte alignment between.
    pad = -(len(blocks[0]) - 8) % 4
    block = blocks[0][8:] + b'\x00' * pad
    size = len(block)
    if size % 8 or blocks[1][8:] != (block * 3)[:len(block) * 3 - pad]:  # pragma: no cover
        raise RuntimeError('visualization_msgs/Marker does not tile: cannot build markers fast')
    offsets = {'id': block.index(struct.pack('<i', _ID)), 'x': block.index(struct.pack('<d', _X)),
               'y': block.index(struct.pack('<d', _Y)),
               'rgba': block.index(struct.pack('<4f', *_RGBA))}
    if offsets != _MARKER_OFFSETS or block[:8] != bytes(8):  # pragma: no cover
        raise RuntimeError(f'visualization_msgs/Marker fields moved: {offsets}')
    return size, pad, block


def markers_cdr(poses: np.ndarray, states: np.ndarray | None, body_radius: float,
                ns: int, *, palette: Sequence[Sequence[float]]) -> bytes:
    """visualization_msgs/MarkerArray: one cylinder per robot (ns 'robots', id = robot),
    coloured by controller state: RGBA ``palette[state]`` (the kind's states' colours; a
    code beyond it takes the last; without states, the first)."""
    poses = np.asarray(poses, dtype=np.float64).reshape(-1, 3)
    n = len(poses)
    states = np.zeros(n, dtype=np.uint8) if states is None else np.asarray(states)
    size, pad, block = _marker_layout(float(body_radius))
    offsets = _MARKER_OFFSETS
    out = np.tile(np.frombuffer(block, dtype=np.uint8), n).reshape(n, size)
    # The header's stamp opens each marker's block.
    out[:, 0:8] = np.frombuffer(struct.pack('<iI', ns // 1_000_000_000, ns % 1_000_000_000),
                                dtype=np.uint8)
    out[:, offsets['id']:offsets['id'] + 4] = \
        np.arange(n, dtype='<i4')[:, None].view(np.uint8)
    for key, column in (('x', 0), ('y', 1)):
        out[:, offsets[key]:offsets[key] + 8] = \
            np.ascontiguousarray(poses[:, column], dtype='<f8')[:, None].view(np.uint8)
    colours = np.asarray(palette, dtype='<f4')[np.minimum(states, len(palette) - 1)]
    out[:, offsets['rgba']:offsets['rgba'] + 16] = np.ascontiguousarray(colours).view(np.uint8)
    return CDR_LE + struct.pack('<I', n) + out.tobytes()[:n * size - pad if n else 0]
