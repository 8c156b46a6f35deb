"""The world's messages as CDR bytes, without ROS: what the embedded runner records and serves.

The world node publishes rclpy messages and the metrics node records the CDR bytes that
arrive; the embedded runner has no rclpy, so it builds the same messages here with rosbags'
Jazzy type store (and numpy for the big ones), byte for byte what rclpy sends except for
padding bytes, which no reader looks at. The bag writer, the embedded recorder and the live
view all take their bytes from here, so a bag and the live view carry the same messages.
"""

from __future__ import annotations

import json
import struct

import numpy as np

from swarm_metrics.bag_writer import TYPESTORE

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
WORLD_FRAME = 'world'
#: RGBA per controller state (FOLLOW, AVOID, WAIT, TURN of mona_controller.controller): the
#: colours of the live view's markers and of the videos.
STATE_COLOURS = ((0.20, 0.75, 0.25, 1.0),  # follow: green
                 (1.00, 0.60, 0.00, 1.0),  # avoid: orange
                 (0.90, 0.10, 0.10, 1.0),  # wait (and clean): red
                 (0.25, 0.45, 1.00, 1.0))  # turn: blue
#: The drawn height of a robot's cylinder marker (m).
MARKER_HEIGHT = 0.05


def serialize(msg: object, msgtype: str) -> bytes:
    """Any message of the Jazzy type store as little-endian CDR."""
    return bytes(TYPESTORE.serialize_cdr(msg, msgtype))


def _time(ns: int):
    return TYPES['builtin_interfaces/msg/Time'](sec=ns // 1_000_000_000,
                                                nanosec=ns % 1_000_000_000)


def _header(ns: int, frame: str = WORLD_FRAME):
    return TYPES['std_msgs/msg/Header'](stamp=_time(ns), frame_id=frame)


def _header_cdr(ns: int, frame: str) -> bytes:
    """A Header's CDR after the encapsulation: stamp, then the frame id (NUL-terminated)."""
    name = frame.encode() + b'\x00'
    return struct.pack('<iII', ns // 1_000_000_000, ns % 1_000_000_000, len(name)) + name


def string_cdr(text: str) -> bytes:
    """std_msgs/String."""
    name = text.encode() + b'\x00'
    return CDR_LE + struct.pack('<I', len(name)) + name


def json_cdr(document: dict) -> bytes:
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
    world node fills it (swarm_world.world_messages.PoseArrayFiller), in one numpy pass."""
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


def cue_mono8(cue: np.ndarray) -> np.ndarray:
    """The cue raster as uint8, rounded as the ground sensors read it (row 0 at y = 0)."""
    return np.clip(np.rint(cue), 0, 255).astype(np.uint8)


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
    scaled = np.clip(np.rint(cue.astype(np.float64) * (100.0 / 255.0)), 0, 100).astype(np.int8)
    info = TYPES['nav_msgs/msg/MapMetaData'](
        map_load_time=_time(ns), resolution=float(cell_size), width=cols, height=rows,
        origin=TYPES['geometry_msgs/msg/Pose'](
            position=TYPES['geometry_msgs/msg/Point'](x=0.0, y=0.0, z=0.0),
            orientation=TYPES['geometry_msgs/msg/Quaternion'](x=0.0, y=0.0, z=0.0, w=1.0)))
    msg = TYPES[OCCUPANCY_GRID](header=_header(ns), info=info, data=scaled.ravel())
    return serialize(msg, OCCUPANCY_GRID)


def states_cdr(states: np.ndarray) -> bytes:
    """std_msgs/UInt8MultiArray: each robot's controller state (0 follow, 1 avoid, 2 wait,
    3 turn), robot i at index i (``/world/robot_states``)."""
    data = np.asarray(states, dtype=np.uint8)
    # MultiArrayLayout with no dimensions and offset 0, then the bytes.
    return CDR_LE + struct.pack('<III', 0, 0, len(data)) + data.tobytes()


def states_from_cdr(data: bytes) -> np.ndarray:
    """The states of a ``/world/robot_states`` message."""
    return np.asarray(TYPESTORE.deserialize_cdr(data, UINT8_ARRAY).data, dtype=np.uint8)


def markers_cdr(poses: np.ndarray, states: np.ndarray | None, body_radius: float,
                ns: int) -> bytes:
    """visualization_msgs/MarkerArray: one cylinder per robot (ns 'robots', id = robot),
    coloured by controller state (:data:`STATE_COLOURS`; without states, wait colour for
    none)."""
    marker_type, colour_type = (TYPES['visualization_msgs/msg/Marker'],
                                TYPES['std_msgs/msg/ColorRGBA'])
    point, quaternion = TYPES['geometry_msgs/msg/Point'], TYPES['geometry_msgs/msg/Quaternion']
    vector, duration = (TYPES['geometry_msgs/msg/Vector3'],
                        TYPES['builtin_interfaces/msg/Duration'])
    colours = [colour_type(r=r, g=g, b=b, a=a) for r, g, b, a in STATE_COLOURS]
    header = _header(ns)
    scale = vector(x=2 * body_radius, y=2 * body_radius, z=MARKER_HEIGHT)
    orientation = quaternion(x=0.0, y=0.0, z=0.0, w=1.0)
    states = np.zeros(len(poses), dtype=np.uint8) if states is None else states
    markers = []
    for k, ((x, y, _), state) in enumerate(zip(np.asarray(poses).tolist(), states.tolist())):
        markers.append(marker_type(
            header=header, ns='robots', id=k, type=3, action=0,  # CYLINDER, ADD
            pose=TYPES['geometry_msgs/msg/Pose'](position=point(x=x, y=y, z=MARKER_HEIGHT / 2),
                                                 orientation=orientation),
            scale=scale, color=colours[state], lifetime=duration(sec=0, nanosec=0),
            frame_locked=False, points=[], colors=[], texture_resource='',
            texture=TYPES['sensor_msgs/msg/CompressedImage'](
                header=_header(0, ''), format='', data=np.zeros(0, dtype=np.uint8)),
            uv_coordinates=[], text='', mesh_resource='',
            mesh_file=TYPES['visualization_msgs/msg/MeshFile'](
                filename='', data=np.zeros(0, dtype=np.uint8)),
            mesh_use_embedded_materials=False))
    return serialize(TYPES[MARKER_ARRAY](markers=markers), MARKER_ARRAY)
