"""Conversions of the world's own topics (docs/interfaces.md, "World"): poses, cue map and
grid, robot, obstacle and source markers, the robots' states. The per-robot messages are
:mod:`mona_controller.ros.messages`.
"""

from __future__ import annotations

import array
from collections.abc import Sequence

import numpy as np
from geometry_msgs.msg import Point, Pose, PoseArray
from nav_msgs.msg import OccupancyGrid
from sensor_msgs.msg import Image
from std_msgs.msg import ColorRGBA, UInt8MultiArray
from visualization_msgs.msg import Marker, MarkerArray

from mona_controller.contract import WORLD_FRAME
from mona_controller.ros.messages import ns_to_stamp, set_stamp
from swarm_world.arena import Arena
from swarm_world.frames import poses_from_rows, yaw_to_quaternion
from swarm_world.messages import markers as arena_markers
from swarm_world.messages.cue_map import cue_mono8, cue_percent

# --- poses --------------------------------------------------------------------------------

class PoseArrayFiller:
    """Reuses one PoseArray (and its Pose objects) for [N, 3] poses, yaw in the quaternion."""

    def __init__(self, frame_id: str = WORLD_FRAME) -> None:
        self.msg = PoseArray()
        self.msg.header.frame_id = frame_id
        self._spare: list[Pose] = []

    def fill(self, poses: np.ndarray, stamp_ns: int) -> PoseArray:
        """The message for ``poses`` [N, 3] (x m, y m, yaw rad) at ``stamp_ns``."""
        n = len(poses)
        while len(self._spare) < n:
            self._spare.append(Pose())
        qz, qw = yaw_to_quaternion(poses[:, 2])
        rows = np.column_stack((poses[:, 0], poses[:, 1], qz, qw)).tolist()
        for pose, (x, y, qz, qw) in zip(self._spare, rows):
            pose.position.x = x
            pose.position.y = y
            pose.orientation.z = qz
            pose.orientation.w = qw
        self.msg.poses = self._spare[:n]
        set_stamp(self.msg.header.stamp, stamp_ns)
        return self.msg


def poses_from_pose_array(msg: PoseArray) -> np.ndarray:
    """[N, 3] float64 (x, y, yaw) from a PoseArray (yaw from a z-axis quaternion)."""
    return poses_from_rows([(p.position.x, p.position.y, p.orientation.z, p.orientation.w)
                            for p in msg.poses])


# --- the cue map ------------------------------------------------------------------------

def cue_image(cue: np.ndarray, stamp_ns: int) -> Image:
    """The cue as a mono8 Image, row 0 at the **top** (max y), as image viewers expect."""
    rows, cols = cue.shape
    msg = Image(height=rows, width=cols, encoding='mono8', is_bigendian=0, step=cols)
    msg.header.frame_id = WORLD_FRAME
    msg.header.stamp = ns_to_stamp(stamp_ns)
    msg.data = array.array('B', cue_mono8(cue)[::-1].tobytes())
    return msg


def cue_from_image(msg: Image) -> np.ndarray:
    """The uint8 raster of a ``/world/cue_map`` image, back in core order (row 0 at y = 0)."""
    data = np.frombuffer(msg.data, dtype=np.uint8).reshape(msg.height, msg.step)
    return data[::-1, :msg.width].copy()


def cue_grid(cue: np.ndarray, cell_size: float, stamp_ns: int) -> OccupancyGrid:
    """The cue as an OccupancyGrid scaled to 0..100, origin at the world origin."""
    rows, cols = cue.shape
    msg = OccupancyGrid()
    msg.header.frame_id = WORLD_FRAME
    msg.header.stamp = ns_to_stamp(stamp_ns)
    msg.info.map_load_time = msg.header.stamp
    msg.info.resolution = float(cell_size)
    msg.info.width, msg.info.height = cols, rows
    msg.info.origin.orientation.w = 1.0
    scaled = cue_percent(cue)
    msg.data = array.array('b', scaled.tobytes())
    return msg


def robot_markers(poses: np.ndarray, states: np.ndarray, body_radius: float,
                  stamp_ns: int, *, palette: Sequence[Sequence[float]]) -> MarkerArray:
    """One cylinder per robot (ns 'robots', id = robot), coloured by its controller state:
    RGBA ``palette[state]`` (the kind's states' colours, e.g. BEECLUST's follow green, avoid
    orange, wait and clean red, turn blue), as the embedded runner's
    :func:`swarm_world.messages.cdr.markers_cdr`."""
    out = MarkerArray()
    stamp = ns_to_stamp(stamp_ns)
    colours = [ColorRGBA(r=r, g=g, b=b, a=a) for r, g, b, a in palette]
    last = len(colours) - 1
    for k, (x, y, _) in enumerate(poses.tolist()):
        marker = Marker(ns='robots', id=k, type=Marker.CYLINDER, action=Marker.ADD)
        marker.header.frame_id = WORLD_FRAME
        marker.header.stamp = stamp
        marker.pose.position.x, marker.pose.position.y = x, y
        marker.pose.position.z = arena_markers.ROBOT_HEIGHT / 2
        marker.pose.orientation.w = 1.0
        marker.scale.x = marker.scale.y = 2 * body_radius
        marker.scale.z = arena_markers.ROBOT_HEIGHT
        marker.color = colours[min(int(states[k]), last) if k < len(states) else 0]
        out.markers.append(marker)
    return out


def obstacle_markers(arena: Arena) -> MarkerArray:
    """``/world/obstacles``: one grey marker per obstacle (:mod:`swarm_world.messages.markers`),
    stamp 0; no obstacles, no markers."""
    return _marker_array(arena_markers.obstacle_markers(arena), arena_markers.NAMESPACE,
                         arena_markers.COLOUR, 0)


def source_markers(names: tuple[str, ...], positions: np.ndarray,
                   stamp_ns: int) -> MarkerArray:
    """``/world/sources``: one magenta sphere per source at ``positions`` [S, 2], every
    marker stamped ``stamp_ns`` (:func:`swarm_world.messages.markers.source_markers`)."""
    return _marker_array(arena_markers.source_markers(names, positions.tolist()),
                         arena_markers.SOURCES_NAMESPACE, arena_markers.SOURCE_COLOUR,
                         stamp_ns)


def robot_states(states: np.ndarray) -> UInt8MultiArray:
    """``/world/robot_states``: each robot's controller state, robot i at index i (no layout
    dimensions, as the embedded runner's :func:`swarm_world.messages.cdr.states_cdr`)."""
    return UInt8MultiArray(data=np.asarray(states, dtype=np.uint8).tobytes())


def _marker_array(markers: tuple[arena_markers.MarkerData, ...], namespace: str,
                  rgba: tuple[float, float, float, float], stamp_ns: int) -> MarkerArray:
    out = MarkerArray()
    colour = ColorRGBA(r=rgba[0], g=rgba[1], b=rgba[2], a=rgba[3])
    stamp = ns_to_stamp(stamp_ns)
    for data in markers:
        marker = Marker(ns=namespace, id=data.id, type=data.type, action=arena_markers.ADD,
                        text=data.text)
        marker.header.frame_id = WORLD_FRAME
        marker.header.stamp = stamp
        (marker.pose.position.x, marker.pose.position.y,
         marker.pose.position.z) = data.position
        marker.pose.orientation.w = 1.0
        marker.scale.x, marker.scale.y, marker.scale.z = data.scale
        marker.color = colour
        marker.points = [Point(x=x, y=y, z=z) for x, y, z in data.points]
        out.markers.append(marker)
    return out
