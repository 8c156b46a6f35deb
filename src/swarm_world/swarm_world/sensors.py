"""Mona sensors on the simulated world: two ground sensors and the front IR proximity ring.

Readings are produced in the form a real Mona (and the ROS messages) carry them: ground
readings as uint8 0..255, IR ranges as float32 metres from the body edge (inf = nothing).
"""

from __future__ import annotations

import numpy as np

from swarm_world.cue import cell_index


def ground_readings(cue: np.ndarray, cell_size: float, poses: np.ndarray,
                    wheel_separation: float) -> np.ndarray:
    """The cue under the left and right wheels, [N, 2] uint8 (left, right)."""
    half = wheel_separation / 2
    # The left wheel is at +y in the body frame (REP 103), i.e. at heading + 90 deg.
    ox = -np.sin(poses[:, 2]) * half
    oy = np.cos(poses[:, 2]) * half
    points = np.empty((len(poses), 2, 2))
    points[:, 0, 0] = poses[:, 0] + ox
    points[:, 0, 1] = poses[:, 1] + oy
    points[:, 1, 0] = poses[:, 0] - ox
    points[:, 1, 1] = poses[:, 1] - oy
    idx = cell_index(points, cell_size, cue.shape[0])
    values = cue[idx[..., 1], idx[..., 0]]
    return np.clip(np.rint(values), 0, 255).astype(np.uint8)


def proximity(poses: np.ndarray, body_radius: float, bearings: np.ndarray, ir_range: float,
              arena_side: float) -> tuple[np.ndarray, np.ndarray]:
    """Cast each robot's IR beams against the other robots and the walls.

    Returns:
        ranges: [N, K] float32, distance from the body edge to the first obstacle within
            ``ir_range``, inf where nothing is in range.
        is_robot: [N, K] bool, True where that obstacle is another robot.
    """
    n, k = len(poses), len(bearings)
    wall_hit = np.full((n, k), np.inf)
    robot_hit = np.full((n, k), np.inf)
    reach = body_radius + ir_range  # beam end, from the robot centre
    x, y, theta = poses[:, 0], poses[:, 1], poses[:, 2]

    # Walls: only robots whose beams can reach one need the cast.
    near_wall = np.flatnonzero((x < reach) | (y < reach) | (x > arena_side - reach)
                               | (y > arena_side - reach))
    if len(near_wall):
        angle = theta[near_wall, None] + bearings[None, :]
        ux, uy = np.cos(angle), np.sin(angle)
        px, py = x[near_wall, None], y[near_wall, None]
        with np.errstate(divide='ignore', invalid='ignore'):
            tx = np.where(ux > 0, (arena_side - px) / ux, np.where(ux < 0, -px / ux, np.inf))
            ty = np.where(uy > 0, (arena_side - py) / uy, np.where(uy < 0, -py / uy, np.inf))
        hit = np.minimum(tx, ty)
        wall_hit[near_wall] = np.where(hit <= reach, hit, np.inf)

    # Robots: candidate pairs are closer than two radii plus the range.
    if n > 1:
        dx = x[None, :] - x[:, None]
        dy = y[None, :] - y[:, None]
        close = dx * dx + dy * dy < (2 * body_radius + ir_range) ** 2
        np.fill_diagonal(close, False)
        i, j = np.nonzero(close)
        if len(i):
            angle = theta[i, None] + bearings[None, :]
            ux, uy = np.cos(angle), np.sin(angle)
            ddx, ddy = dx[i, j][:, None], dy[i, j][:, None]
            b = ux * ddx + uy * ddy  # projection of the other centre on the beam
            disc = b * b - (ddx * ddx + ddy * ddy - body_radius * body_radius)
            with np.errstate(invalid='ignore'):
                t = np.maximum(b - np.sqrt(disc), 0.0)  # 0 when the bodies overlap
            valid = (disc >= 0) & (b > 0) & (t <= reach)
            np.minimum.at(robot_hit, i, np.where(valid, t, np.inf))
    best = np.minimum(wall_hit, robot_hit)
    ranges = np.maximum(best - body_radius, 0.0).astype(np.float32)
    return ranges, np.isfinite(best) & (robot_hit < wall_hit)
