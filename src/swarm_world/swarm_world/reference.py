"""Plain-Python references of the fast placement code, and checks against them.

Placement (:mod:`swarm_world.placement`) is fast because it skips work: placed robots are
bucketed in cells, so a spot is checked against its neighbours only. The reference here skips
nothing: every spot against every placed robot and every obstacle, in plain Python, drawing
the same numbers in the same order. So it agrees with the fast code bit for bit, and
:func:`check_placement` says where they do not.

The tests call these checks, and so can any new implementation (the conformance checks ship
with the package, as PettingZoo's do). Pure (no ROS).
"""

from __future__ import annotations

import math

import numpy as np

from swarm_world.arena import Arena
from swarm_world.placement import TRIES_PER_ROBOT, PlacementError, place_robots, placement_rng


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
