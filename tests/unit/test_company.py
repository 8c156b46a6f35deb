"""Cleaning that needs company (``world.cleaning_quorum`` k, ``world.cleaning_range`` r): a
cleaning robot cleans only with k - 1 other cleaning robots within r; k = 1 is eq. 3."""

import numpy as np
import pytest

from swarm_supervisor.config import SwarmConfig
from swarm_supervisor.engine import run_episode
from swarm_supervisor.engine.runner import run_batch
from swarm_world.company import in_company
from swarm_world.world import World


def by_hand(cleaners, poses, quorum, radius):
    """Every pair, in plain Python: the robots with quorum - 1 others within radius."""
    kept = []
    for i in cleaners:
        others = sum(1 for j in cleaners if j != i and
                     (poses[j][0] - poses[i][0]) ** 2 + (poses[j][1] - poses[i][1]) ** 2
                     <= radius * radius)
        if others >= quorum - 1:
            kept.append(i)
    return kept


@pytest.mark.parametrize('seed', range(6))
def test_the_sweep_picks_the_robots_every_pair_does(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 200))
    poses = np.column_stack([rng.uniform(0, 1.0, (n, 2)), rng.uniform(-3, 3, n)])
    poses[1, :2] = poses[0, :2] + (0.2, 0.0)  # exactly r apart: within
    cleaners = np.flatnonzero(rng.random(n) < 0.6)
    for quorum in (1, 2, 3, 5):
        picked = in_company(cleaners, poses, quorum, 0.2)
        assert picked.tolist() == by_hand(cleaners.tolist(), poses.tolist(), quorum, 0.2)
    assert in_company(cleaners[:0], poses, 3, 0.2).size == 0


def stand(world, xy):
    """Robots standing at ``xy`` with their cleaners on, for one cleaning tick."""
    world.reset(np.column_stack([xy, np.zeros(len(xy))]))
    zero = np.zeros(len(xy))
    while world.now < world.params.cleaning_period:  # up to the step of the first tick
        world.step(zero, zero, np.ones(len(xy), dtype=bool))
    return world.cleaned


def test_a_lone_robot_cleans_nothing_when_the_task_needs_two():
    config = SwarmConfig()
    # a pair 12 cm apart, and one robot 60 cm from both, all on the cue
    xy = np.array([[1.30, 1.42], [1.42, 1.42], [1.42, 1.00]])
    paper = World(config.world, config.mona, config.sensing)
    assert stand(paper, xy).tolist() == [0, 1, 2]
    pairs = World(config.replace(world={'cleaning_quorum': 2}).world, config.mona,
                  config.sensing)
    assert stand(pairs, xy).tolist() == [0, 1]
    lone = (slice(95, 105), slice(137, 147))  # the cells under the third robot
    assert np.array_equal(pairs.cue[lone], pairs.initial_cue[lone])
    assert (paper.cue[lone] < paper.initial_cue[lone]).any()
    under_pair = (slice(138, 146), slice(126, 146))
    assert np.array_equal(pairs.cue[under_pair], paper.cue[under_pair])
    triples = World(config.replace(world={'cleaning_quorum': 3}).world, config.mona,
                    config.sensing)
    assert stand(triples, xy).size == 0
    assert np.array_equal(triples.cue, triples.initial_cue)
    wide = World(config.replace(world={'cleaning_quorum': 3, 'cleaning_range': 0.6}).world,
                 config.mona, config.sensing)
    assert stand(wide, xy).tolist() == [0, 1, 2]


def test_needing_company_slows_beeclust_and_batches_keep_the_bits():
    base = SwarmConfig().replace(episode={'population': 30, 'seed': 4, 'duration': 120.0})
    configs = [base.replace(world={'cleaning_quorum': k}) for k in (1, 2, 3)]
    alone = [run_episode(config) for config in configs]
    left = [result.metrics[-1]['mean_cue_fraction'] for result in alone]
    assert left[0] < left[1] < left[2] < 1.0  # BEECLUST waits in groups, so it still cleans
    for lone, batched in zip(alone, run_batch(configs[::-1])[::-1]):
        assert batched.metrics == lone.metrics
        assert np.array_equal(batched.final_cue, lone.final_cue)
