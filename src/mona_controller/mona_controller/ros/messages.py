"""Conversions between the core's arrays and the per-robot messages of docs/interfaces.md.

The world node (or a real Mona driver) builds sensor messages here and the controller node
reads them back; both sides go through these functions, so values cross the wire unchanged:
ground readings as uint8, IR ranges as float32, stamps as integer nanoseconds. (The world's
own topics are converted in :mod:`swarm_world.ros.world_messages`.)

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
from geometry_msgs.msg import TwistStamped
from sensor_msgs.msg import Image, LaserScan

from mona_controller.contract import base_frame
from mona_controller.mona import MonaParams

#: A range this much beyond ``range_max`` (relative) counts as 'nothing in range'.
RANGE_TOLERANCE = 1e-4


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
