"""What the page says a world computes, worked out by the suite itself (plain numpy, none of
the project's kernels): the IR beams from the body edge, the wheels' positions, the paper's
cue and eq. 3's cleaning on it."""

from __future__ import annotations

import math

import numpy as np


def bearings(ir_count: int, ir_span: float) -> np.ndarray:
    """The beams' bearings, right to left: -span/2 + k span/(count-1)."""
    if ir_count == 1:
        return np.zeros(1)
    return np.array([-ir_span / 2 + k * ir_span / (ir_count - 1) for k in range(ir_count)])


def ray_to_walls(x: float, y: float, angle: float, side: float) -> float:
    """Distance from (x, y) along ``angle`` to the walls of [0, side]^2."""
    dx, dy = math.cos(angle), math.sin(angle)
    hits = []
    if dx > 1e-12:
        hits.append((side - x) / dx)
    if dx < -1e-12:
        hits.append(-x / dx)
    if dy > 1e-12:
        hits.append((side - y) / dy)
    if dy < -1e-12:
        hits.append(-y / dy)
    return min(hits)


def ray_to_disc(x: float, y: float, angle: float, cx: float, cy: float,
                radius: float) -> float:
    """Distance from (x, y) along ``angle`` to the disc (cx, cy, radius); inf if missed."""
    dx, dy = math.cos(angle), math.sin(angle)
    ox, oy = cx - x, cy - y
    along = ox * dx + oy * dy
    off = ox * ox + oy * oy - along * along
    if along <= 0 or off > radius * radius:
        return math.inf
    return along - math.sqrt(radius * radius - off)


def beams(poses: np.ndarray, robot: int, angles: np.ndarray, body_radius: float,
          ir_range: float, side: float) -> list[tuple[float, bool, float]]:
    """Robot ``robot``'s beams at ``poses``: (range from the body edge or inf, robot seen,
    the unclipped range) per beam, right to left."""
    x, y, yaw = poses[robot]
    out = []
    for bearing in angles:
        angle = yaw + bearing
        wall = ray_to_walls(x, y, angle, side)
        robot_hit = min((ray_to_disc(x, y, angle, ox, oy, body_radius)
                         for j, (ox, oy, _) in enumerate(poses) if j != robot),
                        default=math.inf)
        hit = min(wall, robot_hit)
        edge = max(hit - body_radius, 0.0)
        seen = edge <= ir_range
        out.append((edge if seen else math.inf, seen and robot_hit < wall, edge))
    return out


def wheel_points(pose, wheel_separation: float) -> tuple[tuple[float, float], ...]:
    """(left, right) wheel positions of a pose: +-separation/2 along the body's y axis."""
    x, y, yaw = pose
    half = wheel_separation / 2
    return ((x - math.sin(yaw) * half, y + math.cos(yaw) * half),
            (x + math.sin(yaw) * half, y - math.cos(yaw) * half))


def paper_cue(world: dict) -> np.ndarray:
    """The paper's initial cue raster (row = y cell, float): peak at the arena centre, falling
    linearly to 0 at the rim, sampled at cell centres."""
    cells = round(world['arena_side'] / world['cell_size'])
    centre = world['arena_side'] / 2
    middle = (np.arange(cells) + 0.5) * world['cell_size'] - centre
    distance = np.hypot(middle[None, :], middle[:, None])
    radius = world['cue_diameter'] / 2
    return np.clip(world['cue_peak'] * (1 - distance / radius), 0.0, None)


def clean(cue: np.ndarray, poses: np.ndarray, world: dict) -> None:
    """Eq. 3 in place (monotone): each pose's 9 x 9 patch loses peak - sqrt(p^2 + q^2)."""
    size, radius = world['cell_size'], world['cleaning_radius']
    cells = cue.shape[0]
    for x, y, _ in poses:
        col = min(max(math.floor(x / size), 0), cells - 1)
        row = min(max(math.floor(y / size), 0), cells - 1)
        for p in range(-radius, radius + 1):
            for q in range(-radius, radius + 1):
                r, c = row + p, col + q
                if 0 <= r < cells and 0 <= c < cells:
                    amount = max(world['cleaning_peak'] - math.hypot(p, q), 0.0)
                    cue[r, c] = max(cue[r, c] - amount, 0.0)


def cue_at(cue: np.ndarray, point: tuple[float, float], cell_size: float) -> float:
    """The raster's value under a point."""
    cells = cue.shape[0]
    col = min(max(math.floor(point[0] / cell_size), 0), cells - 1)
    row = min(max(math.floor(point[1] / cell_size), 0), cells - 1)
    return float(cue[row, col])
