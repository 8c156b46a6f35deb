"""Plain-Python references of the fast sensing and placement code, and checks against them.

The IR kernel (:mod:`swarm_world.sensing.ir`) is fast because it skips work: cell lists
find a robot's neighbours, an approximate beam direction rules most of them out, a bounding
box rules out the obstacles far away, and the walls are tested only near them. Placement
(:mod:`swarm_world.placement`) buckets the placed robots in cells. The references here skip
nothing: every robot against every other one, every shape, the exact direction of every beam,
every spot against every placed robot, in plain Python (no numba), with the same arithmetic
per beam, pair and shape and the same random draws. So they agree with the fast code bit for
bit, and :func:`check_ir` and :func:`check_placement` say where they do not.
:func:`marched_ir` is an independent oracle: it walks along each beam in small steps and asks
what the point is in, with none of the ray algebra, so it agrees with both to within its step.

The tests call these checks, and so can any new implementation of the kernels (the
conformance checks ship with the package, as PettingZoo's do). Pure (no ROS).
"""

from __future__ import annotations

import math

import numpy as np

from swarm_world.arena import Arena, Disc, Obstacle
from swarm_world.placement import TRIES_PER_ROBOT, PlacementError, place_robots, placement_rng
from swarm_world.sensing.ir import proximity


def ir_ring(poses: np.ndarray, body_radius: float, bearings: np.ndarray, ir_range: float,
            arena: Arena) -> tuple[np.ndarray, np.ndarray]:
    """The IR ring the simplest way: what :func:`swarm_world.sensing.ir.proximity` computes.

    A beam from robot i's centre at its heading + bearing sees the nearest of: the walls
    (tested when the robot is within reach of one, as the kernel does), every obstacle, and
    every other robot's disc; a tie goes to the wall or obstacle. The range is from the body
    edge (0 when closer), inf beyond ``ir_range``.

    Returns:
        ranges: [N, K] float32; is_robot: [N, K] bool.
    """
    poses = np.asarray(poses, dtype=np.float64).reshape(-1, 3)
    n, k = len(poses), len(bearings)
    reach = body_radius + ir_range
    close = (2.0 * body_radius + ir_range) ** 2  # farther centres cannot be seen
    ranges = np.empty((n, k), dtype=np.float32)
    is_robot = np.zeros((n, k), dtype=bool)
    for i in range(n):
        x, y, heading = (float(v) for v in poses[i])
        near_wall = x < reach or y < reach or x > arena.side - reach or y > arena.side - reach
        dx, dy = poses[:, 0] - x, poses[:, 1] - y
        others = [j for j in np.flatnonzero(~(dx * dx + dy * dy >= close)) if j != i]  # NaN in
        for b in range(k):
            ux, uy = math.cos(heading + bearings[b]), math.sin(heading + bearings[b])
            hit = math.inf
            if near_wall and _ray_walls(x, y, ux, uy, arena.side) <= reach:
                hit = _ray_walls(x, y, ux, uy, arena.side)
            for obstacle in arena.obstacles:
                t = _ray_obstacle(x, y, ux, uy, obstacle)
                if t <= reach and t < hit:
                    hit = t
            for j in others:
                t = _ray_robot(x, y, ux, uy, float(poses[j, 0]), float(poses[j, 1]),
                               body_radius)
                if t <= reach and t < hit:
                    hit, is_robot[i, b] = t, True
            edge = hit - body_radius  # NaN stays NaN
            ranges[i, b] = np.float32(0.0 if edge < 0.0 else edge)
    return ranges, is_robot


def _ray_walls(x: float, y: float, ux: float, uy: float, side: float) -> float:
    """Along the beam to the walls of the square [0, side]^2 (negative beyond one)."""
    tx = (side - x) / ux if ux > 0 else (-x / ux if ux < 0 else math.inf)
    ty = (side - y) / uy if uy > 0 else (-y / uy if uy < 0 else math.inf)
    return min(tx, ty)


def _ray_robot(x: float, y: float, ux: float, uy: float, cx: float, cy: float,
               radius: float) -> float:
    """Along the beam to another robot's disc: 0 when the bodies overlap it, inf if it
    misses or lies behind."""
    dx, dy = cx - x, cy - y
    along = ux * dx + uy * dy
    disc = along * along - ((dx * dx + dy * dy) - radius * radius)
    if disc < 0.0 or along <= 0.0:
        return math.inf
    return max(along - math.sqrt(disc), 0.0)


def _ray_obstacle(x: float, y: float, ux: float, uy: float, obstacle: Obstacle) -> float:
    """Along the beam to an obstacle: a disc (0 from inside), or the nearest of a polygon's
    edges (ends included, an edge parallel to the beam is not hit)."""
    if isinstance(obstacle, Disc):
        dx, dy = obstacle.x - x, obstacle.y - y
        along = ux * dx + uy * dy
        outside = dx * dx + dy * dy - obstacle.radius * obstacle.radius
        if outside <= 0.0:
            return 0.0
        disc = along * along - outside
        return along - math.sqrt(disc) if along > 0.0 and disc >= 0.0 else math.inf
    hit = math.inf
    for (ax, ay), (bx, by) in obstacle.edges:
        ex, ey = bx - ax, by - ay
        across = ux * ey - uy * ex
        if across == 0.0:
            continue
        wx, wy = ax - x, ay - y
        t = (wx * ey - wy * ex) / across
        s = (wx * uy - wy * ux) / across
        if t >= 0.0 and 0.0 <= s <= 1.0:
            hit = min(hit, t)
    return hit


def marched_ir(poses: np.ndarray, body_radius: float, bearings: np.ndarray, ir_range: float,
               arena: Arena, step: float = 1e-4) -> tuple[np.ndarray, np.ndarray]:
    """An independent oracle: walk along every beam from the body edge in ``step`` (m) until
    the point is in another robot, beyond a wall or in an obstacle. Agrees with
    :func:`ir_ring` to within ``step`` except where a beam grazes something.

    Returns:
        ranges: [N, K] float64 (inf: nothing within range); is_robot: [N, K] bool.
    """
    poses = np.asarray(poses, dtype=np.float64).reshape(-1, 3)
    ranges = np.full((len(poses), len(bearings)), np.inf)
    is_robot = np.zeros(ranges.shape, dtype=bool)
    for i, (x, y, heading) in enumerate(poses):
        others = np.delete(poses[:, :2], i, axis=0)
        for b, bearing in enumerate(bearings):
            for t in np.arange(body_radius, body_radius + ir_range + step, step):
                px = x + t * math.cos(heading + bearing)
                py = y + t * math.sin(heading + bearing)
                if np.any(np.hypot(others[:, 0] - px, others[:, 1] - py) <= body_radius):
                    ranges[i, b], is_robot[i, b] = t - body_radius, True
                    break
                if arena.clearance(px, py) < 0.0:
                    ranges[i, b] = t - body_radius
                    break
    return ranges, is_robot


def check_ir(poses: np.ndarray, body_radius: float, bearings: np.ndarray, ir_range: float,
             arena: Arena) -> tuple[np.ndarray, np.ndarray]:
    """Cast the IR ring with :func:`swarm_world.sensing.ir.proximity` and with
    :func:`ir_ring`.

    Returns:
        The fast readings (ranges, is_robot), once they equal the reference's bit for bit
        (any NaN equals any NaN).

    Raises:
        AssertionError: naming the first robot and beam where they differ, and both values.
    """
    fast = proximity(poses, body_radius, np.asarray(bearings, dtype=np.float64), ir_range,
                     arena.side, arena.packed)
    slow = ir_ring(poses, body_radius, bearings, ir_range, arena)
    for name, got, expected in (('ranges', fast[0], slow[0]), ('is_robot', fast[1], slow[1])):
        first_difference(f'IR {name}', got, expected, ('robot', 'beam'))
    return fast


def placement(population: int, arena: Arena, body_radius: float, rng: np.random.Generator, *,
              gap: float = 0.005, tries_per_robot: int = TRIES_PER_ROBOT) -> np.ndarray:
    """:func:`swarm_world.placement.place_robots` the simplest way: a spot drawn uniformly
    within ``gap`` of the walls is kept if it is at least 2 radii + ``gap`` from every placed
    robot and a radius + ``gap`` from every obstacle; then the heading is drawn.

    Returns:
        [population, 3] float64 poses.

    Raises:
        PlacementError: a robot found no spot in ``tries_per_robot`` draws.
    """
    low, high = body_radius + gap, arena.side - body_radius - gap
    poses = np.empty((population, 3))
    for k in range(population):
        for _ in range(tries_per_robot):
            x, y = rng.uniform(low, high, size=2)
            placed = poses[:k]
            crowded = np.any((placed[:, 0] - x) ** 2 + (placed[:, 1] - y) ** 2
                             < (2 * body_radius + gap) ** 2)
            blocked = any(obstacle.clearance(float(x), float(y)) < body_radius + gap
                          for obstacle in arena.obstacles)
            if not (crowded or blocked):
                break
        else:
            raise PlacementError(f'robot {k} found no free spot in {tries_per_robot} tries')
        poses[k] = (x, y, rng.uniform(-math.pi, math.pi))
    return poses


def check_placement(population: int, arena: Arena, body_radius: float, seed: int, *,
                    gap: float = 0.005) -> np.ndarray:
    """Place ``population`` robots from ``placement_rng(seed)`` with
    :func:`~swarm_world.placement.place_robots` and with :func:`placement`.

    Returns:
        The fast poses, once they equal the reference's bit for bit.

    Raises:
        AssertionError: naming the first robot and column (x, y, heading) where they differ.
    """
    fast = place_robots(population, arena.side, body_radius, placement_rng(seed), gap=gap,
                        obstacles=arena.obstacles)
    slow = placement(population, arena, body_radius, placement_rng(seed), gap=gap)
    first_difference('placement poses', fast, slow, ('robot', 'column'))
    return fast


def first_difference(what: str, got: np.ndarray, expected: np.ndarray,
                     axes: tuple[str, ...]) -> None:
    """Raise AssertionError naming the first index where two arrays differ in their bits
    (any NaN equals any NaN), e.g. ``IR ranges differ first at robot 3, beam 1: ...``.

    Args:
        axes: the name of each axis, for the message.
    """
    got, expected = np.asarray(got), np.asarray(expected)
    if got.shape != expected.shape or got.dtype != expected.dtype:
        raise AssertionError(f'{what}: shape or type {got.shape} {got.dtype} against the '
                             f"reference's {expected.shape} {expected.dtype}")
    if got.dtype.kind == 'f':
        bits = np.dtype(f'u{got.dtype.itemsize}')
        same = (got.view(bits) == expected.view(bits)) | (np.isnan(got) & np.isnan(expected))
    else:
        same = got == expected
    if not same.all():
        index = tuple(int(v) for v in np.argwhere(~same)[0])
        where = ', '.join(f'{axis} {v}' for axis, v in zip(axes, index))
        raise AssertionError(f'{what} differ first at {where}: {got[index]!r}, the reference '
                             f'{expected[index]!r}')
