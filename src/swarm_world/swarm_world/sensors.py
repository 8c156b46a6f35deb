"""Mona sensors on the simulated world: two ground sensors and the front IR proximity ring.

Readings are produced in the form a real Mona (and the ROS messages) carry them: ground
readings as uint8 0..255, IR ranges as float32 metres from the body edge (inf = nothing).

The two kernels are compiled with numba: a plain loop over robots, beams and neighbours reads
as the geometry it implements and runs in microseconds, where the vectorised numpy version
spent most of a step on call overhead. Both runners use these same functions.
"""

from __future__ import annotations

import math

import numba
import numpy as np


@numba.njit(cache=True)
def _ground_kernel(cue, cell_size, poses, half_separation, out):  # pragma: no cover - jitted
    last = cue.shape[0] - 1
    for i in range(poses.shape[0]):
        x, y, heading = poses[i, 0], poses[i, 1], poses[i, 2]
        # The left wheel is at +y in the body frame (REP 103): offset (-sin, cos) * half.
        ox = -math.sin(heading) * half_separation
        oy = math.cos(heading) * half_separation
        for side in range(2):
            sign = 1.0 if side == 0 else -1.0
            col = min(max(math.floor((x + sign * ox) / cell_size), 0), last)
            row = min(max(math.floor((y + sign * oy) / cell_size), 0), last)
            out[i, side] = np.uint8(min(max(np.rint(cue[row, col]), 0.0), 255.0))
    return out


def ground_readings(cue: np.ndarray, cell_size: float, poses: np.ndarray,
                    wheel_separation: float) -> np.ndarray:
    """The cue cell under the left and right wheels, rounded: [N, 2] uint8 (left, right)."""
    out = np.empty((len(poses), 2), dtype=np.uint8)
    return _ground_kernel(cue, cell_size, np.ascontiguousarray(poses, dtype=np.float64),
                          wheel_separation / 2, out)


@numba.njit(cache=True)
def _proximity_kernel(poses, body_radius, bearings, ir_range, arena_side, hit,
                      is_robot):  # pragma: no cover - jitted
    n, k = poses.shape[0], bearings.shape[0]
    reach = body_radius + ir_range  # a beam's end, from the robot centre
    close = (2.0 * body_radius + ir_range) ** 2  # farther centres cannot be seen
    radius_sq = body_radius * body_radius
    for i in range(n):
        x, y, heading = poses[i, 0], poses[i, 1], poses[i, 2]
        near_wall = x < reach or y < reach or x > arena_side - reach or y > arena_side - reach
        for b in range(k):
            hit[i, b] = np.inf
            is_robot[i, b] = False
            if near_wall:
                ux, uy = math.cos(heading + bearings[b]), math.sin(heading + bearings[b])
                tx = (arena_side - x) / ux if ux > 0 else (-x / ux if ux < 0 else np.inf)
                ty = (arena_side - y) / uy if uy > 0 else (-y / uy if uy < 0 else np.inf)
                if min(tx, ty) <= reach:
                    hit[i, b] = min(tx, ty)
        for j in range(n):
            dx, dy = poses[j, 0] - x, poses[j, 1] - y
            distance_sq = dx * dx + dy * dy
            if j == i or distance_sq >= close:
                continue
            for b in range(k):
                ux, uy = math.cos(heading + bearings[b]), math.sin(heading + bearings[b])
                along = ux * dx + uy * dy  # projection of the other centre on the beam
                disc = along * along - (distance_sq - radius_sq)
                if disc < 0.0 or along <= 0.0:
                    continue  # the beam misses the disc, or points away from it
                t = max(along - math.sqrt(disc), 0.0)  # 0 when the bodies overlap
                if t <= reach and t < hit[i, b]:
                    hit[i, b] = t
                    is_robot[i, b] = True
    return hit, is_robot


def proximity(poses: np.ndarray, body_radius: float, bearings: np.ndarray, ir_range: float,
              arena_side: float) -> tuple[np.ndarray, np.ndarray]:
    """Cast each robot's IR beams (from its centre, at ``bearings``) against robots and walls.

    Returns:
        ranges: [N, K] float32, distance from the body edge to the first obstacle within
            ``ir_range``, inf where nothing is in range.
        is_robot: [N, K] bool, True where that obstacle is another robot.
    """
    n, k = len(poses), len(bearings)
    hit, is_robot = _proximity_kernel(
        np.ascontiguousarray(poses, dtype=np.float64), body_radius,
        np.ascontiguousarray(bearings, dtype=np.float64), ir_range, arena_side,
        np.empty((n, k)), np.empty((n, k), dtype=np.bool_))
    return np.maximum(hit - body_radius, 0.0).astype(np.float32), is_robot
