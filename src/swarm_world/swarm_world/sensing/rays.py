"""Where an IR beam meets the arena: one ray test per kind of shape (:func:`ray_walls`,
:func:`ray_disc`, :func:`ray_segment`), and the nearest static obstacle of a robot's beams
(:func:`cast_obstacles`, the obstacles packed in flat arrays by :mod:`swarm_world.arena`).
Compiled with numba, called by the IR kernel (:mod:`swarm_world.sensing.ir`).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from swarm_world.arena import SEGMENT_RAYS

#: A beam is skipped on its approximate direction only when it misses by more than this (m,
#: m^2): the approximation is within 1e-12 of the exact direction (headings below
#: :data:`swarm_world.sensing.ir.TRUSTED_HEADING`), so the exact test would skip it too.
MARGIN = 1e-9


@numba.njit(cache=True)
def ray_walls(x: float, y: float, ux: float, uy: float,
              side: float) -> float:  # pragma: no cover - jitted
    """The distance along the beam from (x, y) in direction (ux, uy) to the walls of the
    square [0, side]^2 (negative from beyond a wall; inf along a wall)."""
    tx = (side - x) / ux if ux > 0 else (-x / ux if ux < 0 else np.inf)
    ty = (side - y) / uy if uy > 0 else (-y / uy if uy < 0 else np.inf)
    return min(tx, ty)


@numba.njit(cache=True)
def ray_disc(x: float, y: float, ux: float, uy: float, cx: float, cy: float,
             radius: float) -> float:  # pragma: no cover - jitted
    """The distance along the beam from (x, y) in direction (ux, uy) to the disc of centre
    (cx, cy): 0 from inside it, inf if it misses (a tangent beam touches it, if rounding
    leaves it tangent)."""
    dx, dy = cx - x, cy - y
    along = ux * dx + uy * dy  # the centre's foot on the beam
    outside = dx * dx + dy * dy - radius * radius
    if outside <= 0.0:
        return 0.0
    disc = along * along - outside
    if along > 0.0 and disc >= 0.0:
        return along - math.sqrt(disc)
    return np.inf  # points away, or passes by (also NaN)


@numba.njit(cache=True)
def ray_segment(x: float, y: float, ux: float, uy: float, ax: float, ay: float, bx: float,
                by: float) -> float:  # pragma: no cover - jitted
    """The distance along the beam from (x, y) in direction (ux, uy) to the segment from
    (ax, ay) to (bx, by), ends included; inf if it misses or runs parallel to it (a beam
    along an edge is seen by the edges at its ends)."""
    ex, ey = bx - ax, by - ay
    across = ux * ey - uy * ex
    if across == 0.0:
        return np.inf
    wx, wy = ax - x, ay - y
    t = (wx * ey - wy * ex) / across
    s = (wx * uy - wy * ux) / across  # where on the segment, 0 at a, 1 at b
    if t >= 0.0 and s >= 0.0 and s <= 1.0:
        return t
    return np.inf


@numba.njit(cache=True)
def _near(boxes: np.ndarray, m: int, x: float, y: float,
          reach: float) -> bool:  # pragma: no cover - jitted
    """Whether a beam of length ``reach`` from (x, y) may reach obstacle m's bounding box
    (widened by MARGIN: a skip test, it must never skip a hit)."""
    reach = reach + MARGIN
    near: bool = (x + reach >= boxes[m, 0] and x - reach <= boxes[m, 2]
                  and y + reach >= boxes[m, 1] and y - reach <= boxes[m, 3])
    return near


@numba.njit(cache=True)
def near_any(boxes: np.ndarray, x: float, y: float,
             reach: float) -> bool:  # pragma: no cover - jitted
    """Whether a beam of length ``reach`` from (x, y) may reach any obstacle's bounding box."""
    for m in range(boxes.shape[0]):
        if _near(boxes, m, x, y, reach):
            return True
    return False


@numba.njit(cache=True)
def cast_obstacles(x: float, y: float, reach: float, boxes: np.ndarray, kinds: np.ndarray,
                   first: np.ndarray, geometry: np.ndarray, ux: np.ndarray, uy: np.ndarray,
                   hit: np.ndarray) -> None:  # pragma: no cover - jitted
    """Lower each beam's hit (exact directions ux, uy) to the nearest obstacle within reach."""
    for m in range(boxes.shape[0]):
        if not _near(boxes, m, x, y, reach):
            continue
        segments = kinds[m] == SEGMENT_RAYS
        for row in range(first[m], first[m + 1]):
            g0, g1 = geometry[row, 0], geometry[row, 1]
            g2, g3 = geometry[row, 2], geometry[row, 3]
            for b in range(ux.shape[0]):
                if segments:
                    t = ray_segment(x, y, ux[b], uy[b], g0, g1, g2, g3)
                else:
                    t = ray_disc(x, y, ux[b], uy[b], g0, g1, g2)
                if t <= reach and t < hit[b]:
                    hit[b] = t
