"""Eq. 3's cleaning as a Webots Display would draw it (``world.cleaning: blend``): 8-bit cells
blended towards 0 with the amount as opacity, against a plain-Python reading of the rule."""

import math

import numpy as np
import pytest

from swarm_supervisor.config import SwarmConfig
from swarm_supervisor.engine import run_episode
from swarm_world import cue as cue_field


def blended(value: float, amount: float) -> float:
    """One cell, as the Display's integer blend computes it (opacity truncated to 8 bits)."""
    opacity = math.floor(amount)
    return float(((255 - opacity) * math.floor(value)) // 255)


def test_a_blended_patch_loses_a_share_of_what_it_holds():
    kernel = cue_field.cleaning_kernel(4, 8.0)
    rng = np.random.default_rng(3)
    cue = rng.uniform(0, 255, size=(40, 40)).astype(np.float32)
    cue[20, 20] = 255.0
    cue[20, 24] = 100.0
    before = cue.copy()
    cells = np.array([[20, 20], [22, 19], [0, 0]])  # overlapping patches, and one at a corner
    cue_field.clean(cue, cells, kernel, blend=True)
    expected = before.astype(np.float64)
    for col, row in cells:
        for r in range(max(row - 4, 0), min(row + 5, 40)):
            for c in range(max(col - 4, 0), min(col + 5, 40)):
                expected[r, c] = blended(expected[r, c], kernel[r - row + 4, c - col + 4])
    assert np.array_equal(cue, expected.astype(np.float32))
    assert cue[20, 24] < before[20, 24]  # offset (4, 0): opacity floor(4) = 4
    assert blended(255, 8.0) == 247 and blended(100, 8.0) == 96  # the centre: 8 of 255
    assert blended(1, 8.0) == 0 and blended(255, 2.34) == 253  # a corner's opacity is 2
    assert (cue <= before).all() and (cue == np.floor(cue))[16:25, 16:25].all()


def test_blend_cleans_less_than_monotone_on_a_weak_cue():
    kernel = cue_field.cleaning_kernel(4, 8.0)
    weak = np.full((9, 9), 40.0, dtype=np.float32)
    monotone, blend = weak.copy(), weak.copy()
    cue_field.clean(monotone, np.array([[4, 4]]), kernel)
    cue_field.clean(blend, np.array([[4, 4]]), kernel, blend=True)
    assert monotone[4, 4] == 32.0 and blend[4, 4] == 38.0  # 8 units against 8 / 255 of 40


@pytest.mark.parametrize('mode', ['monotone', 'literal', 'blend'])
def test_every_mode_cleans_in_an_episode_and_never_adds_cue(mode):
    config = SwarmConfig().replace(episode={'population': 30, 'seed': 2, 'duration': 60.0},
                                   world={'cleaning': mode})
    result = run_episode(config)
    fractions = [row['mean_cue_fraction'] for row in result.metrics]
    assert result.encounters > 0 and fractions[-1] < 1.0
    if mode != 'literal':  # the literal rule can raise cells (docs/model.md)
        assert all(b <= a for a, b in zip(fractions, fractions[1:]))
