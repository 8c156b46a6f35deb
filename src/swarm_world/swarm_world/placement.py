"""Randomised initial placement of the swarm, as the Webots supervisor did.

Robots are drawn uniformly on the floor, clear of the walls, of each other and of the arena's
obstacles (:mod:`swarm_world.arena`); :mod:`swarm_world.reference` holds a plain all-pairs
version that :func:`~swarm_world.reference.check_placement` compares this one with.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from swarm_world.arena import Obstacle

#: The random stream id of placement (controllers use another).
PLACEMENT_STREAM = 0
#: Robots may cover at most this fraction of the arena floor.
MAX_COVERAGE = 0.4
#: Attempts per robot before placement gives up.
TRIES_PER_ROBOT = 2000


class PlacementError(ValueError):
    """The population cannot be placed in the arena."""


def _fitting(floor: float, body_radius: float) -> int:
    """How many robots the coverage limit lets onto ``floor`` m^2."""
    return max(0, math.floor(MAX_COVERAGE * floor / (math.pi * body_radius ** 2)))


def _side_for(population: int, body_radius: float, obstacle_area: float) -> float:
    """The smallest arena side (m) that holds ``population`` within the coverage limit,
    rounded up to the centimetre shown."""
    side = math.sqrt(population * math.pi * body_radius ** 2 / MAX_COVERAGE + obstacle_area)
    return math.ceil(side * 100) / 100


def placement_rng(seed: int) -> np.random.Generator:
    """The generator placement draws from for an episode seed."""
    return np.random.default_rng([seed, PLACEMENT_STREAM])


def place_robots(population: int, arena_side: float, body_radius: float,
                 rng: np.random.Generator, *, gap: float = 0.005,
                 tries_per_robot: int = TRIES_PER_ROBOT,
                 obstacles: Sequence[Obstacle] = ()) -> np.ndarray:
    """Uniformly random, non-overlapping poses with uniform headings.

    Robots keep ``gap`` metres from the walls, from the obstacles and from each other, so
    none starts touching. Without obstacles the draws and poses are those of an arena that
    never had any; with them, a spot too close to one is drawn again, as one too close to a
    robot is.

    Args:
        obstacles: the arena's (``WorldParams.arena().obstacles``; default none).

    Returns:
        [population, 3] float64 poses (x m, y m, heading rad in [-pi, pi)).

    Raises:
        PlacementError: if the robots would cover more than 40 % of the floor the obstacles
            leave or rejection sampling does not converge; the message names the population
            and the arena.
    """
    floor = arena_side ** 2 - sum(obstacle.area for obstacle in obstacles)
    coverage = population * math.pi * body_radius ** 2 / floor if floor > 0 else math.inf
    if coverage > MAX_COVERAGE:
        raise PlacementError(
            f'population {population} does not fit a {arena_side} m arena'
            f'{" with its obstacles" if obstacles else ""}: robots of radius '
            f'{body_radius} m would cover {coverage:.0%} of the floor (at most '
            f'{MAX_COVERAGE:.0%}); run a smaller population (at most '
            f'{_fitting(floor, body_radius)} fit) or a bigger world.arena_side (at least '
            f'{_side_for(population, body_radius, arena_side ** 2 - floor):.2f} m for '
            f'{population})')
    low, high = body_radius + gap, arena_side - body_radius - gap
    if low >= high:
        raise PlacementError(f'a robot of radius {body_radius} m does not fit a '
                             f'{arena_side} m arena')
    min_distance = 2 * body_radius + gap
    min_distance_sq = min_distance ** 2
    clearance = body_radius + gap  # from an obstacle, as from a wall
    # The placed robots, bucketed in square cells min_distance wide: a spot can only be too
    # close to robots in its own and the 8 surrounding cells, so a try costs O(1) instead of
    # O(robots placed) (10,000 robots: 0.1 s instead of minutes). The draws, the distance
    # arithmetic and hence the poses are exactly those of checking every placed robot.
    cells: dict[tuple[int, int], list[tuple[float, float]]] = {}
    poses = np.empty((population, 3))
    for k in range(population):
        for _ in range(tries_per_robot):
            x, y = (float(v) for v in rng.uniform(low, high, size=2))
            col, row = math.floor(x / min_distance), math.floor(y / min_distance)
            if not (_crowded(cells, x, y, col, row, min_distance_sq)
                    or _blocked(obstacles, x, y, clearance)):
                break
        else:
            raise PlacementError(f'placing population {population} in a {arena_side} m arena '
                                 f'did not converge: robot {k} found no free spot in '
                                 f'{tries_per_robot} tries')
        cells.setdefault((col, row), []).append((x, y))
        poses[k] = (x, y, rng.uniform(-math.pi, math.pi))
    return poses


def _crowded(cells: dict[tuple[int, int], list[tuple[float, float]]], x: float, y: float,
             col: int, row: int, min_distance_sq: float) -> bool:
    """Whether a placed robot in the 3 x 3 cells around (col, row) is too close to (x, y)."""
    return any((px - x) ** 2 + (py - y) ** 2 < min_distance_sq
               for c in (col - 1, col, col + 1) for r in (row - 1, row, row + 1)
               for px, py in cells.get((c, r), ()))


def _blocked(obstacles: Sequence[Obstacle], x: float, y: float, clearance: float) -> bool:
    """Whether (x, y) is closer than ``clearance`` to an obstacle (or in one)."""
    return any(obstacle.clearance(x, y) < clearance for obstacle in obstacles)
