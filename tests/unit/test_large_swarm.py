"""Large swarms: the fast IR sensing, coherency and placement equal their brute-force
versions on random swarms, and a short N = 2,000 episode keeps the invariants of small ones."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mona_controller.mona import MonaParams
from swarm_metrics.metrics import ALL_PAIRS_MAX, coherency
from swarm_supervisor.config import SwarmConfig
from swarm_supervisor.engine.episode import Episode
from swarm_world.arena import Arena, Disc, Polygon, Rect
from swarm_world.placement import place_robots, placement_rng
from swarm_world.reference import check_ir, check_placement

BEARINGS = MonaParams().ir_bearings()
RADIUS, IR_RANGE = 0.04, 0.03


def random_swarm(rng: np.random.Generator, population: int, side: float) -> np.ndarray:
    """Poses spread over the arena and a little beyond its walls (the collision slop), with
    a dense clump where bodies touch and overlap, as in an aggregate."""
    poses = np.column_stack((rng.uniform(-0.002, side + 0.002, (population, 2)),
                             rng.uniform(-math.pi, math.pi, population)))
    clump = population // 3
    poses[:clump, :2] = rng.normal(side / 2, 0.15, (clump, 2))
    return poses


def all_pairs_coherency(positions: np.ndarray) -> float:
    i, j = np.triu_indices(len(positions), k=1)
    return float(np.hypot(positions[i, 0] - positions[j, 0],
                          positions[i, 1] - positions[j, 1]).mean())


def min_distance(xy: np.ndarray, within: float) -> float:
    """The smallest distance between two points when it is below ``within`` (else inf): a
    sweep along x, so that a 2,000-robot check costs no N^2 array."""
    order = np.argsort(xy[:, 0])
    xs, ys = xy[order, 0], xy[order, 1]
    best = math.inf
    for k in range(1, len(xs)):
        near = xs[k:] - xs[:-k] < within
        if not near.any():
            break
        gaps = np.hypot(xs[k:][near] - xs[:-k][near], ys[k:][near] - ys[:-k][near])
        best = min(best, float(gaps.min()))
    return best


@pytest.mark.parametrize('seed', range(6))
def test_cell_list_ir_equals_all_pairs_bit_for_bit(seed):
    rng = np.random.default_rng([13, seed])
    for population in (0, 1, 2, 7, 60, 400, 1500):
        side = float(rng.uniform(0.5, 2.85 * math.sqrt(max(population, 1) / 50) + 0.5))
        poses = random_swarm(rng, population, side)
        ranges, is_robot = check_ir(poses, RADIUS, BEARINGS, IR_RANGE, Arena(side))
        if population >= 60:
            assert is_robot.any() and np.isfinite(ranges).any()  # they do see each other


def test_cell_list_ir_among_obstacles_equals_all_pairs():
    rng = np.random.default_rng(21)
    side = 2.85 * math.sqrt(1500 / 50)
    arena = Arena(side, (Disc('pillar', 4.0, 4.0, 0.5), Rect.of('wall', 8.0, 2.0, 8.1, 12.0),
                         Polygon('wedge', ((1.0, 10.0), (3.0, 10.5), (2.0, 13.0)))))
    poses = random_swarm(rng, 1500, side)
    for turn in (0.0, 5000.0, 1e5, -3e6):  # headings as pymunk leaves them, past 1e4 too
        ranges, is_robot = check_ir(poses + [0, 0, turn], RADIUS, BEARINGS, IR_RANGE, arena)
        assert is_robot.any() and (np.isfinite(ranges) & ~is_robot).any()


def test_cell_list_ir_in_a_tiny_arena_and_with_a_lost_robot():
    rng = np.random.default_rng(5)
    poses = random_swarm(rng, 30, 0.3)  # narrower than one cell: a 1 x 1 grid
    poses[3] = (np.nan, np.nan, 0.0)  # a robot whose physics failed sees and is seen by none
    poses[4] = (50.0, -50.0, 1.0)  # far outside: clamped into an edge cell
    for arena in (Arena(0.3), Arena(0.3, (Disc('pillar', 0.15, 0.15, 0.03),))):
        ranges, _ = check_ir(poses, RADIUS, BEARINGS, IR_RANGE, arena)
        assert np.isinf(ranges[3]).all()


def test_coherency_equals_all_pairs():
    rng = np.random.default_rng(8)
    for population in (2, 3, 50, ALL_PAIRS_MAX, ALL_PAIRS_MAX + 1, 777, 3000):
        side = 2.85 * math.sqrt(population / 50)
        positions = random_swarm(rng, population, side)[:, :2]
        expected = all_pairs_coherency(positions)
        if population <= ALL_PAIRS_MAX:
            assert coherency(positions) == expected  # the shipped study's numbers, exactly
        else:
            assert coherency(positions) == pytest.approx(expected, rel=1e-12, abs=0)
    assert math.isnan(coherency(np.zeros((1, 2))))


def test_grid_placement_equals_checking_every_placed_robot():
    for seed, population, side in ((1, 30, 2.85), (2, 300, 2.85), (3, 2000, 18.0)):
        check_placement(population, Arena(side), RADIUS, seed)
    pillars = tuple(Disc(f'p{k}', x, y, 0.3) for k, (x, y) in
                    enumerate(((3.0, 3.0), (9.0, 4.0), (14.0, 12.0), (5.0, 15.0))))
    check_placement(2000, Arena(18.0, (*pillars, Rect.of('wall', 8.0, 6.0, 8.2, 14.0))),
                    RADIUS, 4)


def test_ten_thousand_robots_are_placed_apart():
    side = 2.85 * math.sqrt(10_000 / 50)
    poses = place_robots(10_000, side, RADIUS, placement_rng(1))
    assert min_distance(poses[:, :2], 0.2) >= 2 * RADIUS + 0.005


def test_a_short_2000_robot_episode_keeps_the_invariants():
    population = 2000
    side = 2.85 * math.sqrt(population / 50)  # the paper's density (bench_embedded.py)
    config = SwarmConfig().replace(
        episode={'population': population, 'seed': 3, 'duration': 20.0},
        world={'arena_side': side, 'cue_diameter': 2.227 * side / 2.85})
    episode = Episode(config)
    world = episode.world
    previous_cue = world.cue.copy()
    worst_overlap, cleanings = -math.inf, 0
    while not episode.done:
        step = episode.step()
        poses = world.poses
        # No robot leaves the arena (up to pymunk's collision slop).
        assert poses[:, :2].min() >= RADIUS - 1e-3
        assert poses[:, :2].max() <= side - RADIUS + 1e-3
        closest = min_distance(poses[:, :2], 2 * RADIUS + 0.01)
        worst_overlap = max(worst_overlap, 2 * RADIUS - closest)
        # The cue only changes when robots clean, and then never rises.
        if len(step.cleaned):
            cleanings += 1
            assert np.all(world.cue <= previous_cue)
            previous_cue = world.cue.copy()
        if step.sampled:
            assert np.array_equal(world.cue, previous_cue)
            row = episode.metrics()
            assert row['coherency'] == pytest.approx(all_pairs_coherency(poses[:, :2]),
                                                     rel=1e-12)
    assert worst_overlap < 2e-3  # metres, as for small swarms
    # Robots met and cleaned: not a vacuous run.
    assert episode.controllers.encounters.sum() > 100 and cleanings > 5
    assert world.cue.sum() < world.initial_cue.sum()
