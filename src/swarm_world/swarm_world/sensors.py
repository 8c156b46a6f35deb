"""Mona sensors on the simulated world: two ground sensors and the front IR proximity ring.

Readings are produced in the form a real Mona (and the ROS messages) carry them: ground
readings as uint8 0..255, IR ranges as float32 metres from the body edge (inf = nothing).
"""

from __future__ import annotations

import numpy as np


def ground_readings(cue: np.ndarray, cell_size: float, poses: np.ndarray,
                    wheel_separation: float, cos: np.ndarray | None = None,
                    sin: np.ndarray | None = None) -> np.ndarray:
    """The cue under the left and right wheels, [N, 2] uint8 (left, right).

    ``cos`` and ``sin`` of the headings may be passed in when already known.
    """
    if cos is None:
        cos, sin = np.cos(poses[:, 2]), np.sin(poses[:, 2])
    half = wheel_separation / 2
    # The left wheel is at +y in the body frame (REP 103): offset (-sin, cos) * half.
    side = np.array([1.0, -1.0])
    cols = (poses[:, 0, None] - np.multiply.outer(sin * half, side)) / cell_size
    rows = (poses[:, 1, None] + np.multiply.outer(cos * half, side)) / cell_size
    last = cue.shape[0] - 1
    cols = np.clip(cols, 0, last).astype(np.int64)  # clip first: no float->int overflow
    rows = np.clip(rows, 0, last).astype(np.int64)
    return np.rint(cue[rows, cols]).astype(np.uint8)


def all_pairs_within(positions: np.ndarray, distance: float) -> np.ndarray:
    """Every ordered pair (i, j), i != j, of points closer than ``distance``: [P, 2].

    The brute-force broadphase; the world gets the same pairs from pymunk's sensor rings.
    """
    delta = positions[None, :, :] - positions[:, None, :]
    close = np.einsum('ijk,ijk->ij', delta, delta) < distance * distance
    np.fill_diagonal(close, False)
    return np.argwhere(close)


def proximity(poses: np.ndarray, body_radius: float, bearings: np.ndarray, ir_range: float,
              arena_side: float, *, near_wall: np.ndarray | None = None,
              pairs: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Cast each robot's IR beams against the other robots and the walls.

    Args:
        near_wall: robots that may see a wall (default: computed from the poses).
        pairs: [P, 2] (robot, other) pairs that may see each other (default: brute force).
            Passing a superset changes nothing; only speed.

    Returns:
        ranges: [N, K] float32, distance from the body edge to the first obstacle within
            ``ir_range``, inf where nothing is in range.
        is_robot: [N, K] bool, True where that obstacle is another robot.
    """
    n, k = len(poses), len(bearings)
    reach = body_radius + ir_range  # beam end, from the robot centre
    x, y, theta = poses[:, 0], poses[:, 1], poses[:, 2]
    if near_wall is None:
        near_wall = np.flatnonzero((x < reach) | (y < reach) | (x > arena_side - reach)
                                   | (y > arena_side - reach))
    if pairs is None:
        pairs = all_pairs_within(poses[:, :2], 2 * body_radius + ir_range)
    best = np.full((n, k), np.inf)
    is_robot = np.zeros((n, k), dtype=bool)
    if len(near_wall) == 0 and len(pairs) == 0:
        return best.astype(np.float32), is_robot
    # Beam directions as unit complex numbers: heading times bearing, no trig per beam.
    beams = np.exp(1j * bearings)
    heading = np.exp(1j * theta)

    if len(near_wall):
        u = heading[near_wall, None] * beams
        ux, uy = u.real, u.imag
        px, py = x[near_wall, None], y[near_wall, None]
        with np.errstate(divide='ignore', invalid='ignore'):
            tx = np.where(ux > 0, (arena_side - px) / ux, np.where(ux < 0, -px / ux, np.inf))
            ty = np.where(uy > 0, (arena_side - py) / uy, np.where(uy < 0, -py / uy, np.inf))
        hit = np.minimum(tx, ty)
        hit[hit > reach] = np.inf
        best[near_wall] = hit

    if len(pairs):
        i = pairs[:, 0]
        centres = x + 1j * y
        offset = centres[pairs[:, 1]] - centres[i]  # from robot i to the other centre
        # Projection of the other centre on each beam: Re(u * conj(offset)).
        b = (heading[i, None] * beams * offset.conj()[:, None]).real
        gap = (offset.real ** 2 + offset.imag ** 2 - body_radius * body_radius)[:, None]
        disc = b * b - gap
        with np.errstate(invalid='ignore'):
            t = np.maximum(b - np.sqrt(disc), 0.0)  # 0 when the bodies overlap
        t[(disc < 0) | (b <= 0) | (t > reach)] = np.inf
        robot_hit = np.full((n, k), np.inf)
        np.minimum.at(robot_hit, i, t)
        is_robot = robot_hit < best
        np.minimum(best, robot_hit, out=best)
    ranges = np.maximum(best - body_radius, 0.0).astype(np.float32)
    return ranges, is_robot
