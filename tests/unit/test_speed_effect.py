"""Table 2's speed effect in robots (swarm_supervisor.analysis.speed_effect): the ratio is the
ANOVA's, the population a speed effect is worth is read off the population effects, and a
power-law cleaning rate gives the ratio its exponents imply."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from swarm_supervisor.analysis.anova import anova
from swarm_supervisor.analysis.speed_effect import (
    PAPER_RATIO,
    equivalent_population,
    main,
    power_law_ratio,
    power_law_speed_worth,
    speed_effect,
)

POPULATIONS = (10, 20, 30, 40, 50)


def additive_table(effects: dict[int, float], slow_extra: float) -> pd.DataFrame:
    """A tidy table whose mean cue is 100 + a_N (+ slow_extra at 4 cm/s) + a time trend +
    a small seed term, so the main effects are known exactly."""
    rows = []
    for n, a in effects.items():
        for speed in (0.04, 0.08):
            for seed in (1, 2, 3):
                for t in range(0, 101, 10):
                    cue = 100 + a + (slow_extra if speed == 0.04 else 0) - 0.1 * t + 0.5 * seed
                    rows.append({'population': n, 'speed': speed, 'seed': seed, 't': float(t),
                                 'mean_cue': cue, 'mean_cue_fraction': cue / 100,
                                 'ratio_near_source': 0.5, 'coherency': 1.0})
    return pd.DataFrame(rows)


def test_the_ratio_is_the_anovas_and_the_equivalent_population_is_read_off_the_effects():
    effects = {10: 40.0, 20: 20.0, 30: 0.0, 40: -20.0, 50: -40.0}  # linear: 2 units a robot
    table = additive_table(effects, slow_extra=20.0)
    result = speed_effect(table)
    frame = anova(table, 'mean_cue').set_index('factor')
    assert result.ratio == pytest.approx(frame.loc['speed', 'sum_sq']
                                         / frame.loc['population', 'sum_sq'])
    assert result.difference == pytest.approx(20.0)
    # 20 units of speed are worth 10 robots: N = 50 at 4 cm/s is N = 40 at 8 cm/s.
    assert result.like == pytest.approx(40.0)
    assert (result.slow, result.fast, result.top) == (0.04, 0.08, 50)
    # With linear effects both readings of the paper's ratio agree.
    assert result.needed_like == pytest.approx(result.needed_like_linear)


def test_the_papers_ratio_needs_a_speed_worth_about_18_robots_if_effects_are_linear():
    result = speed_effect(additive_table({n: -float(n) for n in POPULATIONS}, 5.0))
    assert PAPER_RATIO == pytest.approx(0.4262, abs=1e-4)
    assert result.needed_like_linear == pytest.approx(50 - math.sqrt(8 * PAPER_RATIO) * 10)
    assert result.needed_like_linear == pytest.approx(31.5, abs=0.05)


def test_saturating_effects_need_a_larger_speed_effect_than_linear_ones():
    # Most of the population effect between 10 and 20 robots, as when cleaning saturates.
    effects = {10: 60.0, 20: 0.0, 30: -15.0, 40: -20.0, 50: -25.0}
    result = speed_effect(additive_table(effects, slow_extra=5.0))
    assert result.like == pytest.approx(40.0)  # 5 units: from -25 at 50 to -20 at 40
    assert result.needed_like < result.needed_like_linear


def test_equivalent_population_interpolates_and_says_when_it_is_outside():
    effects = pd.Series({10: 30.0, 30: 10.0, 50: 0.0})
    assert equivalent_population(effects, 0.0) == 50.0
    assert equivalent_population(effects, 5.0) == pytest.approx(40.0)
    assert equivalent_population(effects, 20.0) == pytest.approx(20.0)
    assert math.isnan(equivalent_population(effects, 31.0))


def test_an_unbalanced_or_one_speed_table_is_refused():
    table = additive_table({10: 1.0, 50: 0.0}, 1.0)
    with pytest.raises(ValueError, match='two speeds'):
        speed_effect(table[table['speed'] == 0.08])
    with pytest.raises(ValueError, match='balanced'):
        speed_effect(table[~((table['population'] == 10) & (table['seed'] == 3)
                             & (table['speed'] == 0.04))])


def test_power_law_ratios_grow_with_what_speed_is_worth_in_robots():
    assert power_law_ratio(1.0, 0.0) == pytest.approx(0.0, abs=1e-12)  # speed changes nothing
    encounters = power_law_ratio(2.0, 1.0)  # doubling speed: x 1.41 robots
    solitary = power_law_ratio(1.0, 1.0)  # doubling speed: x 2 robots
    assert 0.05 < encounters < 0.15 < solitary < PAPER_RATIO
    # The same worth in robots gives about the same ratio, whatever the exponents.
    assert power_law_ratio(1.0, 0.5) == pytest.approx(encounters, rel=0.1)
    # A swarm that barely cleans gives speed its largest share: in that limit the cue cleaned
    # is k N v t, and for a = b = 1 the ratio is 5 (v_8 - v_4)^2 mean(N)^2 / (4 sum (N -
    # mean(N))^2 mean(v)^2) = 5 x 0.04^2 x 30^2 / (4 x 1000 x 0.06^2) = 1/2.
    assert power_law_ratio(1.0, 1.0, halves=(30, 0.08, 1e12)) == pytest.approx(0.5, rel=1e-6)
    assert power_law_ratio(2.0, 1.0, halves=(30, 0.08, 1e12)) > encounters
    # What the paper's ratio needs a doubled speed to be worth: about twice the robots.
    b = power_law_speed_worth()
    assert power_law_ratio(1.0, b) == pytest.approx(PAPER_RATIO)
    assert 1.9 < 2 ** b < 2.1


def test_the_command_prints_the_effect_and_refuses_a_missing_file(tmp_path, capsys):
    path = tmp_path / 'all_metrics.csv'
    additive_table({10: 40.0, 30: 0.0, 50: -40.0}, 20.0).to_csv(path, index=False)
    assert main([str(path)]) == 0
    out = capsys.readouterr().out
    assert 'N = 50 at 4 cm/s performs like N = 40.0 at 8 cm/s' in out
    assert f'| {np.round(power_law_ratio(2.0, 1.0), 3):.3f} |' in out
    assert '| N = 30 at 8 cm/s halving the cue at 1500 s | N = 24.5 (speed worth x 2.04) |' \
        in out
    assert main([str(tmp_path / 'missing.csv')]) == 2
