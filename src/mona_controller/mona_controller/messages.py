"""Conversions between the core's arrays and the ROS messages of docs/interfaces.md.

The world node (or a real Mona driver) builds sensor messages here and the controller node
reads them back; both sides go through these functions, so values cross the wire unchanged:
ground readings as uint8, IR ranges as float32, stamps as integer nanoseconds.

Readings coming in from the outside are untrusted: :func:`ground_from_image` and
:func:`proximity_from_scan` reject malformed messages with :class:`ReadingError` and sanitize
bad values (NaN, infinities, negative or out-of-range distances) so the controller core only
ever sees what a healthy sensor could report.
"""

from __future__ import annotations

import array
import math

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Pose, PoseArray, TwistStamped
from nav_msgs.msg import OccupancyGrid
from sensor_msgs.msg import Image, LaserScan
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

from mona_controller.mona import MonaParams
from mona_controller.qos import WORLD_FRAME, base_frame

#: A range this much beyond ``range_max`` (relative) counts as 'nothing in range'.
RANGE_TOLERANCE = 1e-4
MARKER_HEIGHT = 0.05  # m, the drawn height of a robot cylinder


class ReadingError(ValueError):
    """A sensor message that cannot be a Mona reading (wrong shape or encoding)."""


# --- time ---------------------------------------------------------------------------------

def ns_to_stamp(ns: int) -> Time:
    """A builtin_interfaces/Time for ``ns`` nanoseconds (exact)."""
    return Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


def set_stamp(stamp: Time, ns: int) -> None:
    """Set an existing Time in place (cheaper than building one per message)."""
    stamp.sec, stamp.nanosec = divmod(ns, 1_000_000_000)


def stamp_to_ns(stamp: Time) -> int:
    """The integer nanoseconds of a stamp (exact; ``ns / 1e9`` is the time in seconds)."""
    return stamp.sec * 1_000_000_000 + stamp.nanosec


# --- sensor readings ----------------------------------------------------------------------

def ground_image(robot_id: int) -> Image:
    """An empty ``ground`` message for a robot: 1 x 2 mono8, [left, right]."""
    msg = Image(height=1, width=2, encoding='mono8', is_bigendian=0, step=2)
    msg.header.frame_id = base_frame(robot_id)
    msg.data = array.array('B', b'\x00\x00')
    return msg


def proximity_scan(robot_id: int, mona: MonaParams) -> LaserScan:
    """An empty ``proximity`` message for a robot: one beam per IR sensor, right to left."""
    bearings = mona.ir_bearings()
    msg = LaserScan(angle_min=float(bearings[0]), angle_max=float(bearings[-1]),
                    angle_increment=float(bearings[1] - bearings[0]) if len(bearings) > 1
                    else 0.0, range_min=0.0, range_max=float(mona.ir_range))
    msg.header.frame_id = base_frame(robot_id)
    return msg


def fill_readings(ground_msg: Image, scan: LaserScan, ground: np.ndarray, ranges: np.ndarray,
                  is_robot: np.ndarray, stamp_ns: int) -> None:
    """Write one robot's readings (ground [2] uint8, ranges [K] f32, is_robot [K]) in place."""
    set_stamp(ground_msg.header.stamp, stamp_ns)
    set_stamp(scan.header.stamp, stamp_ns)
    # array.array of the right type code is taken as is (bytes would be checked per value).
    ground_msg.data = array.array('B', ground.tobytes())
    scan.ranges = array.array('f', ranges.astype(np.float32, copy=False).tobytes())
    scan.intensities = array.array('f', is_robot.astype(np.float32).tobytes())


def ground_from_image(msg: Image) -> np.ndarray:
    """The [left, right] uint8 ground readings of a ``ground`` message.

    Raises:
        ReadingError: if it is not a 1 x 2 mono8 image.
    """
    if msg.encoding != 'mono8' or (msg.height, msg.width) != (1, 2) or len(msg.data) != 2:
        raise ReadingError(f'ground must be a 1 x 2 mono8 image, got {msg.height} x '
                           f'{msg.width} {msg.encoding!r} with {len(msg.data)} bytes')
    return np.frombuffer(msg.data, dtype=np.uint8)


def proximity_from_scan(msg: LaserScan, beams: int) -> tuple[np.ndarray, np.ndarray, str]:
    """IR ranges (float32, inf = nothing) and robot flags from a ``proximity`` message.

    Sanitizes the values a faulty sensor or driver may send: NaN and +inf mean nothing in
    range, so does a range beyond ``range_max``; a negative range or -inf is an obstacle in
    contact (0 m); a NaN intensity is not a robot.

    Returns:
        (ranges [beams] float32, is_robot [beams] bool, a note on what was repaired or '').

    Raises:
        ReadingError: if the scan does not have ``beams`` ranges and intensities.
    """
    if len(msg.ranges) != beams or len(msg.intensities) != beams:
        raise ReadingError(f'proximity must carry {beams} ranges and {beams} intensities, got '
                           f'{len(msg.ranges)} and {len(msg.intensities)}')
    ranges = np.frombuffer(msg.ranges, dtype=np.float32)
    intensities = np.frombuffer(msg.intensities, dtype=np.float32)
    is_robot = intensities > 0.5  # NaN compares False
    range_max = msg.range_max
    if not math.isfinite(range_max) or range_max <= 0.0:
        range_max = math.inf
    limit = range_max * (1 + RANGE_TOLERANCE)
    with np.errstate(invalid='ignore'):
        bad = np.isnan(ranges) | (ranges < 0.0) | (np.isfinite(ranges) & (ranges > limit))
    if not bad.any():
        return ranges, is_robot, ''
    clean = ranges.copy()
    clean[np.isnan(clean) | (clean > limit)] = np.inf
    clean[clean < 0.0] = 0.0  # includes -inf
    return clean, is_robot, f'repaired proximity ranges {ranges.tolist()}'


# --- commands -----------------------------------------------------------------------------

def fill_twist(msg: TwistStamped, stamp_ns: int, linear: float, angular: float) -> bool:
    """Write a ``cmd_vel`` in place; a non-finite value becomes 0 (hold still).

    Returns:
        False if a value had to be replaced.
    """
    set_stamp(msg.header.stamp, stamp_ns)
    ok = math.isfinite(linear) and math.isfinite(angular)
    msg.twist.linear.x = float(linear) if ok else 0.0
    msg.twist.angular.z = float(angular) if ok else 0.0
    return ok


def twist_of(msg: TwistStamped) -> tuple[int, float, float]:
    """(stamp ns, linear m/s, angular rad/s) of a ``cmd_vel``."""
    return stamp_to_ns(msg.header.stamp), msg.twist.linear.x, msg.twist.angular.z


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
        half = poses[:, 2] * 0.5
        rows = np.column_stack((poses[:, 0], poses[:, 1], np.sin(half), np.cos(half))).tolist()
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
    out = np.empty((len(msg.poses), 3))
    for k, pose in enumerate(msg.poses):
        q = pose.orientation
        out[k] = (pose.position.x, pose.position.y, 2.0 * math.atan2(q.z, q.w))
    return out


# --- the cue map ------------------------------------------------------------------------

def cue_to_mono8(cue: np.ndarray) -> np.ndarray:
    """The cue raster as uint8, rounded like the ground sensors read it (row 0 at y = 0)."""
    return np.clip(np.rint(cue), 0, 255).astype(np.uint8)


def cue_image(cue: np.ndarray, stamp_ns: int) -> Image:
    """The cue as a mono8 Image, row 0 at the **top** (max y), as image viewers expect."""
    rows, cols = cue.shape
    msg = Image(height=rows, width=cols, encoding='mono8', is_bigendian=0, step=cols)
    msg.header.frame_id = WORLD_FRAME
    msg.header.stamp = ns_to_stamp(stamp_ns)
    msg.data = array.array('B', cue_to_mono8(cue)[::-1].tobytes())
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
    scaled = np.clip(np.rint(cue.astype(np.float64) * (100.0 / 255.0)), 0, 100).astype(np.int8)
    msg.data = array.array('b', scaled.tobytes())
    return msg


def robot_markers(poses: np.ndarray, cleaning: np.ndarray, body_radius: float,
                  stamp_ns: int) -> MarkerArray:
    """One cylinder per robot, green while moving, red while cleaning."""
    out = MarkerArray()
    stamp = ns_to_stamp(stamp_ns)
    green, red = ColorRGBA(g=0.8, a=1.0), ColorRGBA(r=0.9, a=1.0)
    for k, (x, y, _) in enumerate(poses.tolist()):
        marker = Marker(ns='robots', id=k, type=Marker.CYLINDER, action=Marker.ADD)
        marker.header.frame_id = WORLD_FRAME
        marker.header.stamp = stamp
        marker.pose.position.x, marker.pose.position.y = x, y
        marker.pose.position.z = MARKER_HEIGHT / 2
        marker.pose.orientation.w = 1.0
        marker.scale.x = marker.scale.y = 2 * body_radius
        marker.scale.z = MARKER_HEIGHT
        marker.color = red if k < len(cleaning) and cleaning[k] else green
        out.markers.append(marker)
    return out
