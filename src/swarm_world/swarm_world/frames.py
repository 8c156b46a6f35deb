"""Planar poses in quaternions (REP 103: yaw about +z, counter-clockwise), without ROS.

The world publishes poses as quaternions; the world node, the bag reader and the tests turn
them back into yaw with the same formula, so a pose crosses the wire and the bag unchanged.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike


def yaw_to_quaternion(yaw: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(qz, qw) of rotations by ``yaw`` (rad) about the z axis (qx = qy = 0)."""
    half = np.asarray(yaw, dtype=np.float64) * 0.5
    return np.sin(half), np.cos(half)


def yaw_from_quaternion(qz: np.ndarray, qw: np.ndarray) -> np.ndarray:
    """The yaw (rad, in (-pi, pi]) of z-axis quaternions (qz, qw)."""
    yaw: np.ndarray = 2.0 * np.arctan2(qz, qw)
    return yaw


def poses_from_rows(rows: ArrayLike) -> np.ndarray:
    """[N, 3] (x, y, yaw) from rows [N, 4] of (x, y, qz, qw)."""
    rows = np.asarray(rows, dtype=np.float64).reshape(-1, 4)
    return np.column_stack((rows[:, 0], rows[:, 1], yaw_from_quaternion(rows[:, 2], rows[:, 3])))
