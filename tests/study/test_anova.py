"""ANOVA on synthetic tidy tables: a planted effect is found, an absent one is not."""

import numpy as np
import pandas as pd
import pytest

from swarm_supervisor.anova import TABLE_COLUMNS, anova, time_levels, write_anova


def synthetic_table(seed: int, *, population_effect: float, speed_effect: float,
                    time_effect: float, noise: float = 1.0) -> pd.DataFrame:
    """A tidy table (3 populations x 2 speeds x 4 seeds, 101 s) with additive effects."""
    rng = np.random.default_rng(seed)
    rows = []
    for n in (10, 30, 50):
        for v in (0.04, 0.08):
            for s in range(4):
                for t in range(101):
                    value = (population_effect * n / 50 + speed_effect * (v == 0.08)
                             + time_effect * t / 100 + noise * rng.standard_normal())
                    rows.append({'population': n, 'speed': v, 'seed': s, 't': float(t),
                                 'mean_cue': value, 'coherency': value})
    return pd.DataFrame(rows)


@pytest.mark.parametrize('seed', [1, 2, 3])
def test_planted_population_effect_is_significant_and_speed_is_not(seed):
    table = synthetic_table(seed, population_effect=3.0, speed_effect=0.0, time_effect=0.0)
    result = anova(table, 'mean_cue').set_index('factor')
    assert result.loc['population', 'p'] < 1e-6
    assert result.loc['population', 'F'] > 20
    assert result.loc['speed', 'p'] > 0.01
    assert result.loc['time', 'p'] > 0.01
    assert result.loc['population', 'eta_sq'] > result.loc['speed', 'eta_sq']


def test_planted_speed_and_time_effects_are_significant():
    table = synthetic_table(7, population_effect=0.0, speed_effect=2.0, time_effect=4.0)
    result = anova(table, 'coherency').set_index('factor')
    assert result.loc['speed', 'p'] < 1e-6
    assert result.loc['time', 'p'] < 1e-6
    assert result.loc['population', 'p'] > 0.01


def test_table_shape_degrees_of_freedom_and_csv(tmp_path):
    table = synthetic_table(4, population_effect=1.0, speed_effect=1.0, time_effect=1.0)
    result = anova(table, 'mean_cue', levels=5)
    assert list(result['factor']) == ['time', 'population', 'speed', 'residual']
    assert list(result['df']) == [4, 2, 1, 3 * 2 * 4 * 5 - 1 - 4 - 2 - 1]
    assert result['eta_sq'].sum() == pytest.approx(1.0, abs=1e-9)  # balanced design
    np.testing.assert_allclose(time_levels(table, 5), [20, 40, 60, 80, 100])
    path = tmp_path / 'anova.csv'
    write_anova(result, path)
    assert path.read_text().splitlines()[0] == ','.join(TABLE_COLUMNS)
    pd.testing.assert_frame_equal(pd.read_csv(path), result, check_dtype=False)


def test_single_level_factor_is_reported_untested():
    table = synthetic_table(5, population_effect=2.0, speed_effect=0.0, time_effect=0.0)
    result = anova(table[table['speed'] == 0.08], 'mean_cue').set_index('factor')
    assert result.loc['speed', 'levels'] == 1
    assert np.isnan(result.loc['speed', 'F']) and np.isnan(result.loc['speed', 'p'])
    assert result.loc['population', 'p'] < 1e-6


def test_too_few_observations_is_a_clear_error():
    table = synthetic_table(6, population_effect=1.0, speed_effect=1.0, time_effect=1.0)
    one_each = table[(table['seed'] == 0)]
    with pytest.raises(ValueError, match='residual degrees of freedom'):
        anova(one_each[one_each['population'] == 10], 'mean_cue', levels=1)
