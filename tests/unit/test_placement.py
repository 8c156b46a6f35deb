"""Randomised placement: inside, non-overlapping, reproducible, and clear failures."""

import math

import numpy as np
import pytest

from swarm_world.arena import Arena, Disc, Polygon, Rect
from swarm_world.placement import PlacementError, place_robots, placement_rng
from swarm_world.reference import check_placement


def test_placement_is_inside_and_non_overlapping():
    poses = place_robots(50, 2.85, 0.04, placement_rng(7))
    assert poses.shape == (50, 3)
    assert np.all(poses[:, :2] >= 0.04) and np.all(poses[:, :2] <= 2.85 - 0.04)
    delta = poses[:, None, :2] - poses[None, :, :2]
    distance = np.hypot(delta[..., 0], delta[..., 1]) + np.eye(50) * 10
    assert distance.min() >= 0.08
    assert np.all((poses[:, 2] >= -np.pi) & (poses[:, 2] < np.pi))


def test_same_seed_same_placement_other_seed_other():
    a = place_robots(20, 2.85, 0.04, placement_rng(3))
    b = place_robots(20, 2.85, 0.04, placement_rng(3))
    c = place_robots(20, 2.85, 0.04, placement_rng(4))
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)


def test_population_that_cannot_fit_names_population_and_arena():
    with pytest.raises(PlacementError, match=r'population 1000 does not fit a 2.85 m arena'):
        place_robots(1000, 2.85, 0.04, placement_rng(1))


def test_dense_placement_that_does_not_converge_fails_clearly():
    with pytest.raises(PlacementError, match=r'population 400 in a 2.85 m arena did not '
                                             r'converge'):
        place_robots(400, 2.85, 0.04, placement_rng(1), tries_per_robot=1)


def test_placement_keeps_the_gap_from_every_obstacle():
    arena = Arena(1.5, (Disc('pillar', 0.5, 0.5, 0.2), Rect.of('wall', 0.9, 0.1, 1.0, 1.2),
                        Polygon('wedge', ((0.2, 1.0), (0.7, 1.1), (0.3, 1.4)))))
    for seed in range(5):
        poses = check_placement(60, arena, 0.04, seed, gap=0.005)  # equals the reference
        for x, y, _ in poses:
            assert arena.clearance(x, y) >= 0.045 - 1e-12  # walls and obstacles alike
    # With gap 0 a robot may touch an obstacle but never overlap it.
    poses = check_placement(60, arena, 0.04, 9, gap=0.0)
    assert min(arena.clearance(x, y) for x, y, _ in poses) >= 0.04 - 1e-12


def test_without_obstacles_the_draws_are_those_of_a_bare_arena():
    bare = place_robots(40, 2.85, 0.04, placement_rng(5))
    assert np.array_equal(place_robots(40, 2.85, 0.04, placement_rng(5), obstacles=()), bare)
    # With one, only the robots drawn too close to it move: the draws differ from there on.
    (k,) = [k for k, (x, y, _) in enumerate(bare) if math.hypot(x - 1.0, y - 1.0) < 0.3][:1]
    moved = place_robots(40, 2.85, 0.04, placement_rng(5),
                         obstacles=(Disc('pillar', 1.0, 1.0, 0.25),))
    assert np.array_equal(moved[:k], bare[:k]) and not np.array_equal(moved[k], bare[k])


def test_obstacles_leave_less_floor_to_cover():
    wall = Rect.of('block', 0.0, 0.0, 2.85, 2.0)  # leaves a strip of 2.85 x 0.85 m
    with pytest.raises(PlacementError, match=r'population 250 does not fit a 2.85 m arena '
                                             r'with its obstacles: .* cover 52% of the floor'):
        place_robots(250, 2.85, 0.04, placement_rng(1), obstacles=(wall,))
    place_robots(250, 2.85, 0.04, placement_rng(1))  # fits the bare arena
    poses = place_robots(60, 2.85, 0.04, placement_rng(1), obstacles=(wall,))
    assert poses[:, 1].min() >= 2.0 + 0.045
