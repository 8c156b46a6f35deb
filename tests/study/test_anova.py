"""ANOVA on synthetic tidy tables: a planted effect is found, an absent one is not."""

import numpy as np
import pandas as pd
import pytest

from swarm_supervisor.analysis.anova import (
    TABLE_COLUMNS,
    VARIANTS,
    anova,
    anova_sample,
    compare_variants,
    time_levels,
    write_anova,
)


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


# The variants (how time and samples enter) and the design's extra factors.

def with_factor(table: pd.DataFrame, name: str, effect: float, seed: int) -> pd.DataFrame:
    """The table twice, its copies at two levels of design factor ``name`` (the second one
    shifted by ``effect``, with fresh noise so the copies are not identical)."""
    rng = np.random.default_rng(seed)
    low, high = table.copy(), table.copy()
    low[name], high[name] = 0.03, 0.1
    for frame, shift in ((low, 0.0), (high, effect)):
        for response in ('mean_cue', 'coherency'):
            frame[response] = frame[response] + shift + 0.5 * rng.standard_normal(len(frame))
    return pd.concat([low, high], ignore_index=True)


@pytest.mark.parametrize('variant', VARIANTS)
def test_every_variant_finds_a_planted_effect_and_not_an_absent_one(variant):
    table = synthetic_table(11, population_effect=3.0, speed_effect=0.0, time_effect=0.0)
    result = anova(table, 'mean_cue', variant=variant).set_index('factor')
    assert result.loc['population', 'p'] < 1e-6, variant
    assert result.loc['speed', 'p'] > 0.01, variant
    assert result.loc['time', 'p'] > 0.01, variant
    planted_time = synthetic_table(12, population_effect=0.0, speed_effect=0.0,
                                   time_effect=4.0)
    result = anova(planted_time, 'coherency', variant=variant).set_index('factor')
    assert result.loc['time', 'p'] < 1e-6, variant
    assert result.loc['population', 'p'] > 0.01, variant


def test_variants_use_the_observations_they_promise():
    table = synthetic_table(13, population_effect=1.0, speed_effect=1.0, time_effect=1.0)
    episodes = 3 * 2 * 4
    counts = {variant: len(anova_sample(table, 'mean_cue', variant=variant))
              for variant in VARIANTS}
    assert counts == {'levels': episodes * 10, 'samples': episodes * 100,
                      'medians': 3 * 2 * 10, 'covariate': episodes * 10}
    samples = anova_sample(table, 'mean_cue', variant='samples')
    assert sorted(samples['time'].unique()) == list(range(10, 101, 10))
    assert (samples.groupby('time').size() == episodes * 10).all()  # (t - 10, t] per level
    medians = anova_sample(table, 'mean_cue', variant='medians')
    cell = table[(table['population'] == 30) & (table['speed'] == 0.08) & (table['t'] == 40)]
    picked = medians[(medians['population'] == 30) & (medians['speed'] == 0.08)
                     & (medians['time'] == 40)]
    assert picked['mean_cue'].item() == pytest.approx(cell['mean_cue'].median())
    degrees = {variant: anova(table, 'mean_cue', variant=variant).set_index('factor')
               .loc['time', 'df'] for variant in VARIANTS}
    assert degrees == {'levels': 9, 'samples': 9, 'medians': 9, 'covariate': 1}


def test_more_samples_of_one_episode_inflate_f():
    # The same data, the same effects: F grows with the observations taken from each episode
    # (every sample rather than one per time level), without more information.
    table = synthetic_table(14, population_effect=0.5, speed_effect=0.5, time_effect=0.0)
    f = {variant: anova(table, 'mean_cue', variant=variant).set_index('factor')
         .loc['population', 'F'] for variant in ('levels', 'samples', 'medians')}
    assert f['samples'] > 3 * f['levels']


def test_a_linear_time_trend_gets_a_larger_f_as_a_covariate():
    table = synthetic_table(15, population_effect=0.0, speed_effect=0.0, time_effect=1.0)
    levels = anova(table, 'mean_cue', variant='levels').set_index('factor')
    covariate = anova(table, 'mean_cue', variant='covariate').set_index('factor')
    assert covariate.loc['time', 'p'] < 1e-6
    assert covariate.loc['time', 'F'] > 3 * levels.loc['time', 'F']


@pytest.mark.parametrize('variant', VARIANTS)
def test_design_factors_enter_every_variant(variant):
    table = with_factor(synthetic_table(16, population_effect=2.0, speed_effect=0.0,
                                        time_effect=0.0), 'mona.ir_range', 2.0, 17)
    result = anova(table, 'mean_cue', variant=variant).set_index('factor')
    assert list(result.index) == ['time', 'population', 'speed', 'mona.ir_range', 'residual']
    assert result.loc['mona.ir_range', 'levels'] == 2
    assert result.loc['mona.ir_range', 'p'] < 1e-6, variant
    assert result.loc['speed', 'p'] > 0.01, variant
    null = with_factor(synthetic_table(18, population_effect=2.0, speed_effect=0.0,
                                       time_effect=0.0), 'world.cleaning', 0.0, 19)
    result = anova(null, 'mean_cue', variant=variant).set_index('factor')
    assert result.loc['world.cleaning', 'p'] > 0.01, variant


def test_a_design_factor_with_one_level_is_untested_and_time_levels_see_every_episode():
    table = synthetic_table(20, population_effect=2.0, speed_effect=0.0, time_effect=0.0)
    table['mona.ir_range'] = 0.05
    result = anova(table, 'mean_cue').set_index('factor')
    assert np.isnan(result.loc['mona.ir_range', 'F'])
    both = with_factor(table.drop(columns='mona.ir_range'), 'mona.ir_range', 0.0, 21)
    shorter = both[~((both['mona.ir_range'] == 0.1) & (both['t'] > 50))]  # one level ends early
    np.testing.assert_allclose(time_levels(shorter, 5), [10, 20, 30, 40, 50])


def test_compare_variants_and_unknown_variant():
    table = synthetic_table(22, population_effect=3.0, speed_effect=1.0, time_effect=0.0)
    frame = compare_variants(table, 'mean_cue').set_index('factor')
    assert list(frame.columns) == list(VARIANTS)
    assert list(frame.index) == ['time', 'population', 'speed', 'observations']
    assert frame.loc['observations', 'samples'] == 2400
    for variant in VARIANTS:
        assert frame.loc['population', variant] == pytest.approx(
            anova(table, 'mean_cue', variant=variant).set_index('factor')
            .loc['population', 'F'])
    with pytest.raises(ValueError, match='variant must be one of levels'):
        anova(table, 'mean_cue', variant='every')
    with pytest.raises(ValueError, match='variant must be one of levels'):
        compare_variants(table, 'mean_cue', variants=('levels', 'every'))


def test_a_variant_too_small_to_fit_is_nan_not_an_error():
    """Two cells of two seeds: the medians over seeds leave no residual, the others fit."""
    table = synthetic_table(24, population_effect=3.0, speed_effect=1.0, time_effect=0.0)
    table = table[(table['population'] < 50) & (table['speed'] == 0.08)
                  & (table['seed'] < 2)]
    with pytest.raises(ValueError, match='no residual'):
        anova(table, 'mean_cue', levels=1, variant='medians')
    frame = compare_variants(table, 'mean_cue', levels=1).set_index('factor')
    assert frame['medians'].isna().all()
    assert np.isfinite(frame.loc['population', 'levels'])


def test_report_variant_table_covers_both_responses_and_every_variant():
    from swarm_supervisor.analysis.report import variant_table
    table = synthetic_table(23, population_effect=3.0, speed_effect=1.0, time_effect=0.0)
    frame = variant_table(table)
    assert list(frame.columns) == ['response', 'factor', *VARIANTS]
    assert sorted(frame['response'].unique()) == ['coherency', 'mean_cue']
    assert frame.groupby('response').size().tolist() == [4, 4]
