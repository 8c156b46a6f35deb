"""The front IR proximity ring of a simulated Mona: what each beam sees, and how far.

Readings are produced in the form a real Mona (and the ROS messages) carry them: IR ranges
as float32 metres from the body edge (inf = nothing). The kernels are compiled with numba. The
IR kernel finds a robot's neighbours in a uniform grid of cells (cell lists), so a swarm of
10,000 costs what 10,000 robots alone do, not the 10,000^2 pairs. A beam sees the nearest of
the walls, the arena's obstacles (:mod:`swarm_world.arena`, packed in flat arrays) and the
other robots, with one ray test per kind of shape (:mod:`swarm_world.sensing.rays`); an arena
without obstacles pays one test per robot for them. Both runners use these same functions,
and :mod:`swarm_world.reference` holds a plain-Python reference.
"""

from __future__ import annotations

import math
from typing import Any

import numba
import numpy as np

from swarm_world.arena import ObstacleArrays, pack
from swarm_world.sensing.headings import heading_trig
from swarm_world.sensing.rays import MARGIN, cast_obstacles, near_any, ray_walls

#: The IR kernels' results: ranges [N, K] float32, is_robot [N, K] bool.
Pair = tuple[np.ndarray, np.ndarray]
#: The work arrays of :func:`_cast`: cell, start, members, beams, exact.
Scratch = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]
#: No obstacles (the bare square): what the IR kernels take when there are none.
NO_OBSTACLES = pack([])


@numba.njit(cache=True)
def _cell_lists(poses: np.ndarray, arena_side: float, min_width: float, cell: np.ndarray,
                start: np.ndarray, members: np.ndarray
                ) -> tuple[int, float]:  # pragma: no cover - jitted
    """Bucket the robots into a uniform grid of square cells at least ``min_width`` wide.

    Returns (columns, width): the robots of cell c = row * columns + col are
    ``members[start[c]:start[c + 1]]``, in index order (a counting sort into the caller's
    ``cell`` [n], ``start`` [at least _most_cells(n) + 1] and ``members`` [n]). Robots outside
    the arena (within the collision slop, or NaN) go to the nearest edge cell, which only
    widens that cell, so two robots closer than ``min_width`` are always in the same or
    adjacent cells.
    """
    n = poses.shape[0]
    # Never more cells than about 16 per robot: a big sparse arena would otherwise spend a
    # step clearing empty cells. Wider cells are still correct, only less selective (at the
    # paper's density the cap never binds: 10,000 robots fill 366 x 366 cells of 11 cm).
    columns = max(min(int(arena_side / min_width), _most_columns(n)), 1)
    width = arena_side / columns
    cells = columns * columns
    start[:cells + 1] = 0
    for i in range(n):
        col = _cell_of(poses[i, 0], width, columns)
        row = _cell_of(poses[i, 1], width, columns)
        cell[i] = row * columns + col
        start[cell[i]] += 1
    for c in range(1, cells):  # start[c]: the end of cell c
        start[c] += start[c - 1]
    start[cells] = n
    for i in range(n - 1, -1, -1):  # fill each cell from its end: start[c] becomes its start
        start[cell[i]] -= 1
        members[start[cell[i]]] = i
    return columns, width


@numba.njit(cache=True)
def _most_columns(n: int) -> int:  # pragma: no cover - jitted
    """The most grid columns :func:`_cell_lists` uses for n robots."""
    return int(math.sqrt(16.0 * n)) + 1


@numba.njit(cache=True)
def _cell_of(coordinate: float, width: float, columns: int) -> int:  # pragma: no cover
    """The grid column (or row) of a coordinate, clamped to the grid (NaN -> 0)."""
    if not coordinate > 0.0:
        return 0
    if coordinate >= width * columns:
        return columns - 1
    return min(int(coordinate / width), columns - 1)


#: Above this |heading| (rad) every beam's direction is computed exactly.
TRUSTED_HEADING = 1e4


@numba.njit(cache=True)
def _proximity_kernel(poses: np.ndarray, body_radius: float, bearings: np.ndarray,
                      ir_range: float, arena_side: float, boxes: np.ndarray | None,
                      kinds: Any, first: Any, geometry: Any, ranges: np.ndarray,
                      is_robot: np.ndarray
                      ) -> Pair:  # pragma: no cover - jitted
    n, k = poses.shape[0], bearings.shape[0]
    return _cast(poses, heading_trig(poses), body_radius, bearings, ir_range, arena_side,
                 boxes, kinds, first, geometry, ranges, is_robot, *_scratch(n, k))


@numba.njit(cache=True)
def _bare_proximity_kernel(poses: np.ndarray, body_radius: float, bearings: np.ndarray,
                           ir_range: float, arena_side: float, ranges: np.ndarray,
                           is_robot: np.ndarray) -> Pair:  # pragma: no cover - jitted
    # _proximity_kernel without obstacles: four arguments fewer to dispatch (about 0.1 us
    # each, 10 % of a 50-robot call), and None for them compiles _cast without its obstacle
    # tests (numba prunes the `is not None` branches of a None argument).
    return _proximity_kernel(poses, body_radius, bearings, ir_range, arena_side, None, None,
                             None, None, ranges, is_robot)


@numba.njit(cache=True)
def _scratch(n: int, k: int) -> Scratch:  # pragma: no cover - jitted
    """The work arrays of :func:`_cast` for up to n robots and k beams (allocated once per
    call of a kernel, not once per arena)."""
    columns = _most_columns(n)
    return (np.empty(n, dtype=np.int64), np.empty(columns * columns + 1, dtype=np.int64),
            np.empty(n, dtype=np.int64), np.empty((_BEAM_ROWS, k)),
            np.empty(k, dtype=np.bool_))


@numba.njit(cache=True)
def _batch_scratch(bounds: np.ndarray, k: int) -> Scratch:  # pragma: no cover - jitted
    """:func:`_scratch` for the largest arena of a batch (arena e holds robots
    ``bounds[e]:bounds[e + 1]``), shared by all of them."""
    most = 0
    for e in range(bounds.shape[0] - 1):
        most = max(most, bounds[e + 1] - bounds[e])
    return _scratch(most, k)


# The rows of _cast's per-beam work array.
_UX, _UY, _AX, _AY, _HIT, _COS_BEARING, _SIN_BEARING = range(7)
_BEAM_ROWS = 7


@numba.njit(cache=True)
def _cast(poses: np.ndarray, trig: np.ndarray, body_radius: float, bearings: np.ndarray,
          ir_range: float, arena_side: float, boxes: np.ndarray | None, kinds: Any,
          first: Any, geometry: Any, ranges: np.ndarray, is_robot: np.ndarray,
          cell: np.ndarray, start: np.ndarray, members: np.ndarray, beams: np.ndarray,
          exact: np.ndarray) -> Pair:  # pragma: no cover - jitted
    """One arena's IR ring into ranges and is_robot, in the given work arrays; the arena's
    obstacles are boxes, kinds, first (rows of the whole geometry array) as in
    :class:`~swarm_world.arena.ObstacleArrays`, or None for each (no obstacles: compiled
    without the obstacle tests)."""
    n, k = poses.shape[0], bearings.shape[0]
    reach = body_radius + ir_range  # a beam's end, from the robot centre
    close = (2.0 * body_radius + ir_range) ** 2  # farther centres cannot be seen
    radius_sq = body_radius * body_radius
    # Only robots in the 3 x 3 cells around robot i can be closer than sqrt(close): the cost
    # is O(N) for a swarm at bounded density instead of O(N^2). The per-pair arithmetic is the
    # all-pairs loop's, and a beam keeps the nearest hit whatever the order robots are met in,
    # so the readings are bit for bit those of the all-pairs loop.
    columns, width = _cell_lists(poses, arena_side, 2.0 * body_radius + ir_range, cell, start,
                                 members)
    # Per beam: the exact directions, cos and sin of (heading + bearing) (exact[b]: worked
    # out), approximate ones by the angle sum from the heading's, robot i's nearest obstacle
    # from its centre, and the bearings' cosines and sines.
    ux, uy, ax, ay, hit = beams[_UX], beams[_UY], beams[_AX], beams[_AY], beams[_HIT]
    cos_bearing, sin_bearing = beams[_COS_BEARING], beams[_SIN_BEARING]
    for b in range(k):
        cos_bearing[b], sin_bearing[b] = math.cos(bearings[b]), math.sin(bearings[b])
    for i in range(n):
        x, y, heading = poses[i, 0], poses[i, 1], poses[i, 2]
        near_wall = x < reach or y < reach or x > arena_side - reach or y > arena_side - reach
        near_obstacle = False
        if boxes is not None:  # compiled out for an arena without obstacles (None)
            near_obstacle = near_any(boxes, x, y, reach)
        # The exact directions (10 trigonometric calls) cost most of a robot's time: they are
        # worked out for every beam near a wall or an obstacle, else only for a beam that may
        # hit a neighbour by its approximate direction (2 calls per robot), so the readings
        # are those of the exact directions.
        approximate = not near_wall and not near_obstacle and abs(heading) < TRUSTED_HEADING
        aimed = False
        for b in range(k):
            hit[b] = np.inf
            is_robot[i, b] = False
            exact[b] = not approximate
            if not approximate:
                ux[b], uy[b] = math.cos(heading + bearings[b]), math.sin(heading + bearings[b])
            if near_wall:
                t = ray_walls(x, y, ux[b], uy[b], arena_side)
                if t <= reach:
                    hit[b] = t
        # Obstacles before robots: a robot replaces a hit only when strictly nearer, so a
        # tie is a wall (not a robot), as with the walls.
        if boxes is not None:
            if near_obstacle:
                cast_obstacles(x, y, reach, boxes, kinds, first, geometry, ux, uy, hit)
        col, row = _cell_of(x, width, columns), _cell_of(y, width, columns)
        for r in range(max(row - 1, 0), min(row + 2, columns)):
            for c in range(max(col - 1, 0), min(col + 2, columns)):
                here = r * columns + c
                for m in range(start[here], start[here + 1]):
                    j = members[m]
                    dx, dy = poses[j, 0] - x, poses[j, 1] - y
                    distance_sq = dx * dx + dy * dy
                    if j == i or distance_sq >= close:
                        continue
                    if approximate and not aimed:
                        ch, sh = trig[i, 0], trig[i, 1]
                        for b in range(k):
                            ax[b] = ch * cos_bearing[b] - sh * sin_bearing[b]
                            ay[b] = sh * cos_bearing[b] + ch * sin_bearing[b]
                        aimed = True
                    for b in range(k):
                        if not exact[b]:
                            along = ax[b] * dx + ay[b] * dy
                            if (along < -MARGIN
                                    or along * along - (distance_sq - radius_sq) < -MARGIN):
                                continue  # misses for sure: no need of the exact direction
                            ux[b] = math.cos(heading + bearings[b])
                            uy[b] = math.sin(heading + bearings[b])
                            exact[b] = True
                        along = ux[b] * dx + uy[b] * dy  # the other centre on the beam
                        disc = along * along - (distance_sq - radius_sq)
                        if disc < 0.0 or along <= 0.0:
                            continue  # the beam misses the disc, or points away from it
                        t = max(along - math.sqrt(disc), 0.0)  # 0 when the bodies overlap
                        if t <= reach and t < hit[b]:
                            hit[b] = t
                            is_robot[i, b] = True
        for b in range(k):  # from the body edge; NaN stays NaN
            edge = hit[b] - body_radius
            ranges[i, b] = np.float32(0.0 if edge < 0.0 else edge)
    return ranges, is_robot


def proximity(poses: np.ndarray, body_radius: float, bearings: np.ndarray, ir_range: float,
              arena_side: float, obstacles: ObstacleArrays = NO_OBSTACLES,
              ) -> tuple[np.ndarray, np.ndarray]:
    """Cast each robot's IR beams (from its centre, at ``bearings``) against robots, walls
    and obstacles.

    Args:
        obstacles: the arena's obstacles, ``Arena.packed`` (default: none).

    Returns:
        ranges: [N, K] float32, distance from the body edge to the first obstacle within
            ``ir_range``, inf where nothing is in range.
        is_robot: [N, K] bool, True where that obstacle is another robot (False for a wall
            or a static obstacle).
    """
    n, k = len(poses), len(bearings)
    poses = np.ascontiguousarray(poses, dtype=np.float64)
    bearings = np.ascontiguousarray(bearings, dtype=np.float64)
    ranges, is_robot = np.empty((n, k), dtype=np.float32), np.empty((n, k), dtype=np.bool_)
    if not len(obstacles.boxes):
        return _bare_proximity_kernel(poses, body_radius, bearings, ir_range, arena_side,
                                      ranges, is_robot)
    return _proximity_kernel(poses, body_radius, bearings, ir_range, arena_side,
                             obstacles.boxes, obstacles.kinds, obstacles.first,
                             obstacles.geometry, ranges, is_robot)


@numba.njit(cache=True)
def _proximity_many_kernel(poses: np.ndarray, trig: np.ndarray, bounds: np.ndarray,
                           body_radius: np.ndarray, bearings: np.ndarray,
                           ir_range: np.ndarray, arena_side: np.ndarray, boxes: np.ndarray,
                           kinds: np.ndarray, first: np.ndarray, geometry: np.ndarray,
                           obstacle_bounds: np.ndarray, ranges: np.ndarray,
                           is_robot: np.ndarray) -> Pair:  # pragma: no cover - jitted
    # Each episode's robots [bounds[e], bounds[e + 1]) see only each other and their own
    # arena's obstacles, by the one-arena kernel on their own rows: the same arithmetic, so
    # the same readings, as alone.
    work = _batch_scratch(bounds, bearings.shape[1])
    for e in range(bounds.shape[0] - 1):
        lo, hi = bounds[e], bounds[e + 1]
        olo, ohi = obstacle_bounds[e], obstacle_bounds[e + 1]
        _cast(poses[lo:hi], trig[lo:hi], body_radius[e], bearings[e], ir_range[e],
              arena_side[e], boxes[olo:ohi], kinds[olo:ohi], first[olo:ohi + 1], geometry,
              ranges[lo:hi], is_robot[lo:hi], *work)
    return ranges, is_robot


@numba.njit(cache=True)
def _bare_proximity_many_kernel(poses: np.ndarray, trig: np.ndarray, bounds: np.ndarray,
                                body_radius: np.ndarray, bearings: np.ndarray,
                                ir_range: np.ndarray, arena_side: np.ndarray,
                                ranges: np.ndarray,
                                is_robot: np.ndarray) -> Pair:  # pragma: no cover - jitted
    # _proximity_many_kernel when no arena has obstacles: five arrays fewer to pass, and no
    # obstacle arrays to slice per arena.
    work = _batch_scratch(bounds, bearings.shape[1])
    for e in range(bounds.shape[0] - 1):
        lo, hi = bounds[e], bounds[e + 1]
        _cast(poses[lo:hi], trig[lo:hi], body_radius[e], bearings[e], ir_range[e],
              arena_side[e], None, None, None, None, ranges[lo:hi], is_robot[lo:hi], *work)
    return ranges, is_robot


def proximity_many(poses: np.ndarray, trig: np.ndarray, bounds: np.ndarray,
                   body_radius: np.ndarray, bearings: np.ndarray, ir_range: np.ndarray,
                   arena_side: np.ndarray, obstacles: ObstacleArrays | None = None,
                   ) -> tuple[np.ndarray, np.ndarray]:
    """:func:`proximity` for several arenas at once, in one call (the batched engine).

    Args:
        poses: [N, 3] the robots of every arena, arena after arena.
        trig: [N, 2] float64 their :func:`heading_trig`.
        bounds: [E + 1] int64, arena e holds robots ``bounds[e]:bounds[e + 1]``.
        body_radius, ir_range, arena_side: [E] each arena's.
        bearings: [E, K] each arena's IR bearings (the same number of beams in all).
        obstacles: every arena's obstacles, ``arena.pack(arenas)`` (its ``bounds`` [E + 1]
            say whose); None: no arena has any (as when they pack to nothing).

    Returns:
        (ranges [N, K] float32, is_robot [N, K] bool), each arena's rows equal to
        :func:`proximity` of that arena alone.
    """
    n, k = len(poses), bearings.shape[1]
    poses = np.ascontiguousarray(poses, dtype=np.float64)
    bearings = np.ascontiguousarray(bearings, dtype=np.float64)
    ranges, is_robot = np.empty((n, k), dtype=np.float32), np.empty((n, k), dtype=np.bool_)
    if obstacles is None or not len(obstacles.boxes):
        return _bare_proximity_many_kernel(poses, trig, bounds, body_radius, bearings,
                                           ir_range, arena_side, ranges, is_robot)
    return _proximity_many_kernel(poses, trig, bounds, body_radius, bearings, ir_range,
                                  arena_side, *obstacles, ranges, is_robot)
