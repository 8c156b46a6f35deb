"""Randomised placement: inside, non-overlapping, reproducible, and clear failures."""

import numpy as np
import pytest

from swarm_world.placement import PlacementError, place_robots, placement_rng


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
